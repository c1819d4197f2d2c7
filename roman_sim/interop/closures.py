"""Loop closures of any system, read from and written to g2o and CSV files.

A loop closure says: robot ``robot_a``'s body at time ``t_a`` sees robot ``robot_b``'s body
at time ``t_b`` at the relative pose ``T_pa_pb`` (b's body in a's body frame, each body
pose in its robot's own odometry frame: the edge the reference ROMAN back end writes),
optionally with a score (the number of associations behind it). Times are seconds since
the robot's start, as in the exported sequences.

CSV (``.csv``), one closure a line, ``#`` starts a comment, an optional header line::

    robot_a,t_a,robot_b,t_b,x,y,z,qx,qy,qz,qw[,score]

g2o (``.g2o``), the format Kimera-RPGO and the reference ROMAN back end write, read with
gtsam's reader (``gtsam.readG2o``): ``VERTEX_SE3:QUAT key x y z qx qy qz qw`` and
``EDGE_SE3:QUAT key1 key2 x y z qx qy qz qw`` followed by the 21 upper-triangle entries of
the information matrix. Keys are gtsam Symbols: the character ``'a' + i`` for the i-th
robot of the robot order (the reference's ``runs`` order) and the keyframe index; a
timestamps side file (the reference's ``odom_all.time.txt``) gives each keyframe's time,
one line ``robot_id keyframe_index time_ns [anything]``. An edge is a loop closure when a
``# LC: n`` comment precedes it (n is its score) or when it is not an odometry edge (an
odometry edge joins keyframes k and k + 1 of one robot). Quaternions are ``x y z w`` and
must have unit norm (within ``QUAT_TOL``): a non-rigid pose is an error, never normalised.

Every error names the file, the line and what is allowed, before anything is written.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import ConfigError, EvaluationError
from roman_sim.core.trajectory import Trajectory

#: Largest allowed deviation of a quaternion's norm from 1.
QUAT_TOL = 1e-5
CSV_FIELDS = ["robot_a", "t_a", "robot_b", "t_b", "x", "y", "z", "qx", "qy", "qz", "qw", "score"]
VERTEX, EDGE = "VERTEX_SE3:QUAT", "EDGE_SE3:QUAT"
_INFO = 21  # upper triangle of the 6 x 6 information matrix


@dataclass(frozen=True)
class Closure:
    """One loop closure between two robot bodies at two times.

    Attributes:
        robot_a, t_a: the first robot and time (s since its start).
        robot_b, t_b: the second robot and time.
        T_pa_pb: 4x4 pose of b's body in a's body frame (rigid).
        score: association count (None: the file gives none).
        line: line of the file it was read from (0 when made in code).
    """

    robot_a: str
    t_a: float
    robot_b: str
    t_b: float
    T_pa_pb: NDArray[np.float64]
    score: int | None = None
    line: int = 0


def _bad(path: Path, line: int, what: str) -> ConfigError:
    return ConfigError(f"{path}:{line}: {what}")


def _floats(path: Path, line: int, parts: Sequence[str], what: str) -> list[float]:
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise _bad(path, line, f"{what}: not a number in {' '.join(parts)!r}") from None
    if not all(math.isfinite(v) for v in vals):
        raise _bad(path, line, f"{what}: values must be finite numbers")
    return vals


def pose_from_xyz_quat(path: Path, line: int, v: Sequence[float]) -> NDArray[np.float64]:
    """4x4 pose from ``x y z qx qy qz qw``; ConfigError when the quaternion is not of unit norm."""
    q = np.asarray(v[3:7], dtype=np.float64)
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > QUAT_TOL:
        raise _bad(
            path, line, f"quaternion norm {norm:.6g}: a rigid relative pose needs a unit quaternion (qx qy qz qw)"
        )
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat(q / norm).as_matrix()
    T[:3, 3] = v[:3]
    return T


def xyz_quat(T: NDArray[np.float64]) -> list[float]:
    """``x y z qx qy qz qw`` of a 4x4 pose."""
    return [*map(float, T[:3, 3]), *map(float, Rotation.from_matrix(T[:3, :3]).as_quat())]


def _time(path: Path, line: int, text: str, what: str) -> float:
    (t,) = _floats(path, line, [text], what)
    if t < 0:
        raise _bad(path, line, f"{what}: {t} s is negative (times are seconds since the robot's start)")
    return t


def read_csv_closures(path: str | Path) -> list[Closure]:
    """Closures of a CSV file (module docstring); ConfigError naming the line on a malformed one."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{p}: cannot read the closure file ({type(err).__name__})") from None
    out = []
    allowed = ",".join(CSV_FIELDS[:-1]) + "[,score]"
    for n, row in enumerate(csv.reader(io.StringIO(text)), start=1):
        cells = [c.strip() for c in row]
        if not cells or not any(cells) or cells[0].startswith("#"):
            continue
        if cells[0] == "robot_a":
            continue
        if len(cells) not in (11, 12):
            raise _bad(p, n, f"{len(cells)} fields; a closure line is {allowed}")
        vals = _floats(p, n, cells[4:11], "relative pose")
        score = None
        if len(cells) == 12 and cells[11] != "":
            try:
                score = int(cells[11])
            except ValueError:
                raise _bad(p, n, f"score {cells[11]!r}: must be a whole number of associations (>= 0)") from None
            if score < 0:
                raise _bad(p, n, f"score {score}: must be a whole number of associations (>= 0)")
        if not cells[0] or not cells[2]:
            raise _bad(p, n, f"empty robot name; a closure line is {allowed}")
        out.append(
            Closure(
                cells[0],
                _time(p, n, cells[1], "t_a"),
                cells[2],
                _time(p, n, cells[3], "t_b"),
                pose_from_xyz_quat(p, n, vals),
                score,
                n,
            )
        )
    return out


#: Header of the trajectory CSV the reference ROMAN writes (robotdatapy's Kimera-Multi layout).
POSE_CSV_HEADER = ["#timestamp_kf", "x", "y", "z", "qw", "qx", "qy", "qz"]


def read_pose_csv(path: str | Path) -> Trajectory:
    """A trajectory CSV as the reference ROMAN writes it: ``#timestamp_kf,x,y,z,qw,qx,qy,qz``, time in ns."""
    p = Path(path)
    try:
        rows = list(csv.reader(io.StringIO(p.read_text(encoding="utf-8"))))
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{p}: cannot read the trajectory ({type(err).__name__})") from None
    if not rows or [c.strip() for c in rows[0]] != POSE_CSV_HEADER:
        raise ConfigError(f"{p}:1: a trajectory CSV starts with the header {','.join(POSE_CSV_HEADER)}")
    t, T = [], []
    for n, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) != 8:
            raise _bad(p, n, f"{len(row)} fields; a pose line is {','.join(POSE_CSV_HEADER)[1:]} (time in ns)")
        v = _floats(p, n, row, "pose")
        t.append(v[0] / 1e9)
        T.append(pose_from_xyz_quat(p, n, [*v[1:4], *v[5:8], v[4]]))
    try:
        return Trajectory(np.asarray(t), np.asarray(T).reshape(-1, 4, 4))
    except EvaluationError as err:
        raise ConfigError(f"{p}: {err}") from None


def read_times_file(path: str | Path) -> dict[tuple[int, int], float]:
    """``(robot_id, keyframe_index) -> time (s)`` of a g2o timestamps file (``robot_id index time_ns ...``)."""
    p = Path(path)
    try:
        lines = p.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{p}: cannot read the timestamps file ({type(err).__name__})") from None
    out: dict[tuple[int, int], float] = {}
    for n, line in enumerate(lines, start=1):
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        try:
            rid, idx, ns = int(parts[0]), int(parts[1]), int(parts[2])
        except (ValueError, IndexError):
            raise _bad(p, n, "a timestamps line is 'robot_id keyframe_index time_ns' (whole numbers)") from None
        if rid < 0 or idx < 0 or ns < 0:
            raise _bad(p, n, "robot_id, keyframe_index and time_ns must be >= 0")
        out[(rid, idx)] = ns / 1e9
    return out


def _symbol(key: int) -> tuple[int, int]:
    """(robot id, index) of a gtsam Symbol key (character ``'a' + id``)."""
    import gtsam

    s = gtsam.Symbol(key)
    c = s.chr()  # an int in gtsam 4.3's Python binding, a str in some builds
    return (c if isinstance(c, int) else ord(c)) - ord("a"), int(s.index())


@dataclass(frozen=True)
class _Edge:
    line: int
    k1: int
    k2: int
    score: int | None


def _scan_g2o(p: Path) -> list[_Edge]:
    """Check every line of a g2o file; the edges in file order (with the score of a ``# LC: n`` comment)."""
    try:
        lines = p.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{p}: cannot read the closure file ({type(err).__name__})") from None
    edges, pending = [], None
    for n, line in enumerate(lines, start=1):
        parts = line.split()
        if not parts:
            continue
        if parts[0].startswith("#"):
            words = line.lstrip("#").split()
            if len(words) == 2 and words[0] == "LC:":
                try:
                    pending = int(words[1])
                except ValueError:
                    raise _bad(p, n, "'# LC: n' needs a whole number of associations") from None
            continue
        if parts[0] == VERTEX:
            if len(parts) != 9:
                raise _bad(p, n, f"{VERTEX} needs key x y z qx qy qz qw (8 values), got {len(parts) - 1}")
            _floats(p, n, parts[1:], VERTEX)
        elif parts[0] == EDGE:
            if len(parts) != 10 + _INFO:
                raise _bad(
                    p,
                    n,
                    f"{EDGE} needs key1 key2 x y z qx qy qz qw and {_INFO} information entries "
                    f"({9 + _INFO} values), got {len(parts) - 1}",
                )
            if not (parts[1].isdigit() and parts[2].isdigit()):
                raise _bad(p, n, f"{EDGE}: keys must be whole numbers (gtsam Symbol keys), got {parts[1]} {parts[2]}")
            vals = _floats(p, n, parts[3:], EDGE)
            pose_from_xyz_quat(p, n, vals[:7])
            edges.append(_Edge(n, int(parts[1]), int(parts[2]), pending))
            pending = None
        else:
            raise _bad(p, n, f"unsupported tag {parts[0]!r} (allowed: {VERTEX}, {EDGE}, '#' comments)")
    return edges


def read_g2o_closures(path: str | Path, times: dict[tuple[int, int], float], robots: Sequence[str]) -> list[Closure]:
    """Loop closures of a g2o file (gtsam's reader), robots and times from the keys.

    Args:
        path: the g2o file.
        times: ``read_times_file`` of its timestamps file.
        robots: robot names in key order (Symbol character ``'a' + i`` is ``robots[i]``).
    """
    import gtsam

    p = Path(path)
    edges = _scan_g2o(p)
    graph, _ = gtsam.readG2o(str(p), True)
    factors = [graph.at(i) for i in range(graph.size())]
    between = [f for f in factors if isinstance(f, gtsam.BetweenFactorPose3)]
    if len(between) != len(edges) or any(list(f.keys()) != [e.k1, e.k2] for f, e in zip(between, edges)):
        raise ConfigError(f"{p}: gtsam's reader did not read the file's {len(edges)} edges one for one")
    out = []
    for f, e in zip(between, edges):
        (ra, ia), (rb, ib) = _symbol(e.k1), _symbol(e.k2)
        if e.score is None and ra == rb and ib == ia + 1:
            continue  # odometry edge
        for rid, idx in ((ra, ia), (rb, ib)):
            if not 0 <= rid < len(robots):
                letters = ", ".join(f"'{chr(ord('a') + i)}' ({r})" for i, r in enumerate(robots))
                raise _bad(
                    p, e.line, f"key of Symbol character {chr(ord('a') + rid)!r}: no such robot (allowed: {letters})"
                )
            if (rid, idx) not in times:
                raise _bad(
                    p, e.line, f"keyframe {idx} of robot {robots[rid]} (id {rid}) has no time in the timestamps file"
                )
        out.append(
            Closure(
                robots[ra],
                times[(ra, ia)],
                robots[rb],
                times[(rb, ib)],
                np.asarray(f.measured().matrix(), dtype=np.float64),
                e.score,
                e.line,
            )
        )
    return out


def read_closures(
    path: str | Path, times: str | Path | None = None, robots: Sequence[str] | None = None
) -> list[Closure]:
    """Closures of a ``.csv`` or ``.g2o`` file (a g2o file needs its timestamps file and the robot order)."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"--closures {p}: no such file")
    if p.suffix.lower() == ".csv":
        return read_csv_closures(p)
    if p.suffix.lower() == ".g2o":
        if times is None:
            raise ConfigError(f"--closures {p}: a g2o file needs its timestamps file (--times)")
        if not robots:
            raise ConfigError(f"--closures {p}: a g2o file needs the robot order (--robots)")
        return read_g2o_closures(p, read_times_file(times), robots)
    raise ConfigError(f"--closures {p}: unknown file type {p.suffix or '(none)'!r} (allowed: .csv, .g2o)")


def write_csv_closures(path: str | Path, closures: Sequence[Closure]) -> None:
    """Write closures as CSV (header, then one line each; floats exact with ``repr``)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_FIELDS)
    for c in closures:
        pose = [repr(v) for v in xyz_quat(c.T_pa_pb)]
        w.writerow(
            [c.robot_a, repr(float(c.t_a)), c.robot_b, repr(float(c.t_b)), *pose, "" if c.score is None else c.score]
        )
    write_text(path, buf.getvalue())


def write_g2o_closures(
    path: str | Path,
    times_path: str | Path,
    closures: Sequence[Closure],
    robots: Sequence[str],
    info: Sequence[float] = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0),
) -> None:
    """Write closures as a g2o file and its timestamps file, in the reference implementation's key layout.

    Each closure's two body times become keyframes (``gtsam.symbol('a' + robot id, index)``,
    indices in time order per robot); a ``# LC: n`` comment carries the score.
    """
    import gtsam

    rid = {r: i for i, r in enumerate(robots)}
    stamps: dict[str, list[int]] = {r: [] for r in robots}
    for c in closures:
        for r, t in ((c.robot_a, c.t_a), (c.robot_b, c.t_b)):
            stamps[r].append(round(t * 1e9))
    index = {r: {ns: i for i, ns in enumerate(sorted(set(v)))} for r, v in stamps.items()}
    I6 = np.diag(np.asarray(info, dtype=np.float64))
    upper = " ".join(repr(float(I6[i, j])) for i in range(6) for j in range(i, 6))
    lines, time_lines = [], []
    for r in robots:
        for ns, i in index[r].items():
            time_lines.append(f"{rid[r]} {i} {ns} {r}\n")
    for c in closures:
        ka = gtsam.symbol(chr(ord("a") + rid[c.robot_a]), index[c.robot_a][round(c.t_a * 1e9)])
        kb = gtsam.symbol(chr(ord("a") + rid[c.robot_b]), index[c.robot_b][round(c.t_b * 1e9)])
        if c.score is not None:
            lines.append(f"# LC: {int(c.score)}\n")
        lines.append(f"{EDGE} {ka} {kb} {' '.join(repr(v) for v in xyz_quat(c.T_pa_pb))} {upper}\n")
    write_text(path, "".join(lines))
    write_text(times_path, "".join(time_lines))
