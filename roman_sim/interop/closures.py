"""Loop closures of any system, read from and written to g2o and CSV files.

A loop closure says: robot ``robot_a``'s body at time ``t_a`` sees robot ``robot_b``'s body
at time ``t_b`` at the relative pose ``T_pa_pb`` (b's body in a's body frame, each body
pose in its robot's own odometry frame: the edge the reference ROMAN back end writes),
optionally with a score (the number of associations behind it). Times are seconds as the
file gives them: since the robot's start, or since 1970 on an exported sequence's clock
(``roman_sim.interop.stamps`` tells them apart, per file).

CSV (``.csv``), one closure a line, ``#`` starts a comment, an optional header line::

    robot_a,t_a,robot_b,t_b,x,y,z,qx,qy,qz,qw[,score]

g2o (``.g2o``), the format Kimera-RPGO and the reference ROMAN back end write:
``VERTEX_SE3:QUAT key x y z qx qy qz qw`` and ``EDGE_SE3:QUAT key1 key2 x y z qx qy qz qw``
followed by the 21 upper-triangle entries of the information matrix. Keys are gtsam
Symbols (the character in the top 8 bits, the index in the low 56): the character
``'a' + i`` for the i-th robot of the robot order (the reference's ``runs`` order) and the
keyframe index; a timestamps side file (the reference's ``odom_all.time.txt``) gives each
keyframe's time, one line ``robot_id keyframe_index time_ns [anything]``. An edge is a loop
closure when a ``# LC: n`` comment precedes it (n is its score) or when it is not an
odometry edge (an odometry edge joins keyframes k and k + 1 of one robot). Keys written as
a letter and an index (``a12``: the reference's per-pair files, read by
``roman_sim.interop.roman_align``) are the Symbols they name. Quaternions are ``x y z w``
(``quaternion_order="wxyz"``: w first) and must have unit norm (within ``QUAT_TOL``): a
non-rigid pose is an error, never normalised.

The files are read as a stream, one line at a time, into arrays (``ClosureSet``): no text
of the file and no object per line is held, so a file of millions of closures takes the
memory of its numbers. Every error names the file, the line and what is allowed (a value
that is not finite or out of range names its field: ``roman_sim.core.tum.field_problem``),
before anything is written.
"""

from __future__ import annotations

import csv
import io
import math
from array import array
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, TextIO, TypeVar

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import ConfigError, EvaluationError
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import MAX_TIME_S, field_problem, pose_problem, time_problem

#: Largest allowed deviation of a quaternion's norm from 1.
QUAT_TOL = 1e-5
CSV_FIELDS = ["robot_a", "t_a", "robot_b", "t_b", "x", "y", "z", "qx", "qy", "qz", "qw", "score"]
VERTEX, EDGE = "VERTEX_SE3:QUAT", "EDGE_SE3:QUAT"
_INFO = 21  # upper triangle of the 6 x 6 information matrix
_POSE = ("x", "y", "z", "qx", "qy", "qz", "qw")
_SYMBOL_INDEX = (1 << 56) - 1  # a gtsam Symbol's index bits; the character is above them
_CHUNK = 1 << 16  # rows converted to matrices at a time
_T = TypeVar("_T")
#: The order of a file's four quaternion numbers: ``xyzw`` (scipy's, Eigen's coefficients, the
#: default) or ``wxyz`` (w first, as gtsam's ``Rot3.Quaternion`` and robotdatapy's CSV write it).
QuaternionOrder = Literal["xyzw", "wxyz"]
QUATERNION_ORDERS: tuple[QuaternionOrder, ...] = ("xyzw", "wxyz")


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


@dataclass(frozen=True, eq=False)
class ClosureSet:
    """Loop closures as arrays, one row each in file order: what the readers return.

    Iterating gives ``Closure`` objects one at a time (made on demand, none is stored).

    Attributes:
        robots: robot names; ``robot_a`` and ``robot_b`` index them.
        robot_a, robot_b: (N,) int64 robot of each end.
        t_a, t_b: (N,) float64 times (s since the robot's start).
        T_pa_pb: (N, 4, 4) float64 relative poses.
        score: (N,) int64 association counts, -1 where the file gives none.
        line: (N,) int64 line of the file each closure was read from.
        files: for a set read from several files, each file and the number of lines before
            it: their lines are numbered as one text, the files in this order (``locate``
            gives a line's file); empty for one file.
    """

    robots: tuple[str, ...]
    robot_a: NDArray[np.int64]
    t_a: NDArray[np.float64]
    robot_b: NDArray[np.int64]
    t_b: NDArray[np.float64]
    T_pa_pb: NDArray[np.float64]
    score: NDArray[np.int64]
    line: NDArray[np.int64]
    files: tuple[tuple[str, int], ...] = ()

    def __len__(self) -> int:
        return len(self.line)

    def __getitem__(self, i: int) -> Closure:
        s = int(self.score[i])
        return Closure(
            self.robots[self.robot_a[i]],
            float(self.t_a[i]),
            self.robots[self.robot_b[i]],
            float(self.t_b[i]),
            self.T_pa_pb[i].copy(),
            None if s < 0 else s,
            int(self.line[i]),
        )

    def __iter__(self) -> Iterator[Closure]:
        return (self[i] for i in range(len(self)))

    def locate(self, line: int) -> tuple[str | None, int]:
        """The file (None: the set's one file) and the line in it of line ``line`` of the set."""
        name, before = None, 0
        for f, n in self.files:
            if n >= line:
                break
            name, before = f, n
        return name, line - before

    @classmethod
    def concat(cls, parts: Sequence[tuple[ClosureSet, str, int]]) -> ClosureSet:
        """One set of several files' sets: ``(set, file name, the file's number of lines)`` each, in order."""
        names: dict[str, int] = {}
        cols: list[list[NDArray]] = [[] for _ in range(8)]  # type: ignore[type-arg]
        files, before = [], 0
        for cs, name, n_lines in parts:
            code = np.asarray([names.setdefault(r, len(names)) for r in cs.robots], dtype=np.int64)
            for col, v in zip(cols, (code[cs.robot_a], cs.t_a, code[cs.robot_b], cs.t_b, cs.T_pa_pb, cs.score)):
                col.append(v)
            cols[6].append(cs.line + before)
            files.append((name, before))
            before += n_lines
        if not parts:
            return ClosureSet.of([])
        ra, ta, rb, tb, T, score, line = (np.concatenate(c) for c in cols[:7])
        return cls(tuple(names), ra, ta, rb, tb, T.reshape(-1, 4, 4), score, line, tuple(files))

    @classmethod
    def of(cls, closures: Iterable[Closure]) -> ClosureSet:
        """The set of closures made in code (or read one by one)."""
        rows = ClosureRows()
        for c in closures:
            rows.add(c.robot_a, c.t_a, c.robot_b, c.t_b, (), c.score, c.line)
            rows.matrices.append(np.asarray(c.T_pa_pb, dtype=np.float64))
        return rows.done()


class ClosureRows:
    """Columns that grow one closure at a time (``array`` buffers: no object per row)."""

    def __init__(self) -> None:
        self.names: dict[str, int] = {}
        self.ra, self.rb = array("q"), array("q")
        self.ta, self.tb = array("d"), array("d")
        self.pose = array("d")  # x y z qx qy qz qw per row
        self.score, self.line = array("q"), array("q")
        self.matrices: list[NDArray[np.float64]] = []  # ``ClosureSet.of`` only: poses given as matrices

    def code(self, robot: str) -> int:
        """The code of a robot name (a new one for a name not seen yet)."""
        return self.names.setdefault(robot, len(self.names))

    def add(self, ra: str, ta: float, rb: str, tb: float, pose: Sequence[float], score: int | None, line: int) -> None:
        """One closure: its ends, ``x y z`` and the quaternion's four numbers, its score and line."""
        self.ra.append(self.code(ra))
        self.ta.append(ta)
        self.rb.append(self.code(rb))
        self.tb.append(tb)
        self.pose.extend(pose)
        self.score.append(-1 if score is None else score)
        self.line.append(line)

    def done(self, order: QuaternionOrder = "xyzw") -> ClosureSet:
        """The closures added, as a set (their quaternions' numbers in ``order``)."""
        n = len(self.line)
        if self.matrices:
            T = np.stack(self.matrices)
        else:
            T = np_poses(np.frombuffer(self.pose, dtype=np.float64).reshape(n, 7), order)
        return ClosureSet(  # views of the buffers: no copy
            tuple(self.names),
            np.frombuffer(self.ra, dtype=np.int64),
            np.frombuffer(self.ta, dtype=np.float64),
            np.frombuffer(self.rb, dtype=np.int64),
            np.frombuffer(self.tb, dtype=np.float64),
            T.reshape(n, 4, 4),
            np.frombuffer(self.score, dtype=np.int64),
            np.frombuffer(self.line, dtype=np.int64),
        )


def np_poses(v: NDArray[np.float64], order: QuaternionOrder = "xyzw") -> NDArray[np.float64]:
    """(N, 4, 4) poses of (N, 7) rows ``x y z qx qy qz qw`` (quaternions of unit norm within ``QUAT_TOL``;
    ``order="wxyz"``: the rows are ``x y z qw qx qy qz``)."""
    T = np.zeros((len(v), 4, 4))
    T[:, 3, 3] = 1.0
    cols = [3, 4, 5, 6] if order == "xyzw" else [4, 5, 6, 3]
    for s in range(0, len(v), _CHUNK):
        q = v[s : s + _CHUNK][:, cols]
        T[s : s + _CHUNK, :3, :3] = Rotation.from_quat(q / np.linalg.norm(q, axis=1)[:, None]).as_matrix()
        T[s : s + _CHUNK, :3, 3] = v[s : s + _CHUNK, :3]
    return T


def line_error(path: str | Path, line: int, what: str) -> ConfigError:
    """The error ``path:line: what``."""
    return ConfigError(f"{path}:{line}: {what}")


def parse_floats(path: str | Path, line: int, parts: Sequence[str], what: str) -> list[float]:
    """The numbers of ``parts`` (their finiteness is checked by field, where they are used)."""
    try:
        return [float(p) for p in parts]
    except ValueError:
        raise line_error(path, line, f"{what}: not a number in {' '.join(parts)!r}") from None


def check_pose(path: str | Path, line: int, v: Sequence[float], names: Sequence[str] = _POSE) -> None:
    """Check ``x y z qx qy qz qw``: finite, a position in range, a quaternion of unit norm (ConfigError)."""
    bad = pose_problem(names, v)
    if bad is not None:
        raise line_error(path, line, bad)
    norm = math.sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6])
    if not abs(norm - 1.0) <= QUAT_TOL:
        raise line_error(
            path, line, f"quaternion norm {norm:.6g}: a rigid relative pose needs a unit quaternion (qx qy qz qw)"
        )


def pose_from_xyz_quat(path: str | Path, line: int, v: Sequence[float]) -> NDArray[np.float64]:
    """4x4 pose from ``x y z qx qy qz qw``; ConfigError naming the file and line when a value is not
    finite or out of range, or the quaternion is not of unit norm."""
    check_pose(path, line, v)
    q = np.asarray(v[3:7], dtype=np.float64)
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat(q / np.linalg.norm(q)).as_matrix()
    T[:3, 3] = v[:3]
    return T


def xyz_quat(T: NDArray[np.float64]) -> list[float]:
    """``x y z qx qy qz qw`` of a 4x4 pose."""
    return [*map(float, T[:3, 3]), *map(float, Rotation.from_matrix(T[:3, :3]).as_quat())]


def _time(path: str | Path, line: int, text: str, what: str) -> float:
    try:
        t = float(text)
    except ValueError:
        raise line_error(path, line, f"{what}: not a number in {text!r}") from None
    bad = time_problem(what, t)
    if bad is not None:
        raise line_error(path, line, bad)
    if t < 0:
        raise line_error(
            path, line, f"{what}: {t} s is negative (times are seconds since the robot's start or since 1970)"
        )
    return t


def _open(path: Path, what: str) -> TextIO:
    try:
        return path.open(encoding="utf-8", newline="")
    except OSError as err:
        raise ConfigError(f"{path}: cannot read the {what} ({type(err).__name__})") from None


def read_stream(path: str | Path, what: str, parse: Callable[..., _T], *args: object) -> _T:
    """``parse(lines, path, *args)`` over the file's lines, streamed; ConfigError when it cannot be read."""
    p = Path(path)
    fh = _open(p, what)
    try:
        with fh:
            return parse(fh, p, *args)
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{p}: cannot read the {what} ({type(err).__name__})") from None


def parse_csv_closures(
    lines: Iterable[str], source: str | Path = "closures", quaternion_order: QuaternionOrder = "xyzw"
) -> ClosureSet:
    """Closures of CSV lines (module docstring), read one line at a time from any iterable (a file,
    a pipe, a generator); ConfigError naming ``source`` and the line on a malformed one.
    ``quaternion_order``: the order of the four quaternion fields (``wxyz``: the file writes w first)."""
    p = source
    rows = ClosureRows()
    allowed = ",".join(CSV_FIELDS[:-1]) + "[,score]"
    for n, row in enumerate(csv.reader(lines), start=1):
        cells = [c.strip() for c in row]
        if not cells or not any(cells) or cells[0].startswith("#"):
            continue
        if cells[0] == "robot_a":
            continue
        if len(cells) not in (11, 12):
            raise line_error(p, n, f"{len(cells)} fields; a closure line is {allowed}")
        vals = parse_floats(p, n, cells[4:11], "relative pose")
        score = None
        if len(cells) == 12 and cells[11] != "":
            try:
                score = int(cells[11])
            except ValueError:
                raise line_error(p, n, f"score {cells[11]!r}: must be a whole number of associations (>= 0)") from None
            if score < 0:
                raise line_error(p, n, f"score {score}: must be a whole number of associations (>= 0)")
        if not cells[0] or not cells[2]:
            raise line_error(p, n, f"empty robot name; a closure line is {allowed}")
        t_a, t_b = _time(p, n, cells[1], "t_a"), _time(p, n, cells[3], "t_b")
        check_pose(p, n, vals)
        rows.add(cells[0], t_a, cells[2], t_b, vals, score, n)
    return rows.done(quaternion_order)


def read_csv_closures(path: str | Path, quaternion_order: QuaternionOrder = "xyzw") -> ClosureSet:
    """Closures of a CSV file (module docstring), streamed; ConfigError naming the line on a malformed one."""
    return read_stream(path, "closure file", parse_csv_closures, quaternion_order)


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
            raise line_error(p, n, f"{len(row)} fields; a pose line is {','.join(POSE_CSV_HEADER)[1:]} (time in ns)")
        v = parse_floats(p, n, row, "pose")
        bad = field_problem("timestamp_kf", v[0], MAX_TIME_S * 1e9, "ns")
        if bad is not None:
            raise line_error(p, n, bad)
        t.append(v[0] / 1e9)
        T.append(pose_from_xyz_quat(p, n, [*v[1:4], *v[5:8], v[4]]))
    try:
        return Trajectory(np.asarray(t), np.asarray(T).reshape(-1, 4, 4))
    except EvaluationError as err:
        raise ConfigError(f"{p}: {err}") from None


@dataclass(frozen=True, eq=False)
class KeyframeTimes:
    """A g2o timestamps file: each keyframe's time, by its gtsam Symbol key.

    Attributes:
        keys: (M,) uint64 sorted Symbol keys (``'a' + robot_id`` and the keyframe index).
        t: (M,) float64 times (s); a key listed twice keeps its last line's time.
    """

    keys: NDArray[np.uint64]
    t: NDArray[np.float64]

    def lookup(self, keys: NDArray[np.uint64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """The times of ``keys`` and whether each has one."""
        if len(self.keys) == 0:
            return np.zeros(len(keys)), np.zeros(len(keys), dtype=bool)
        i = np.clip(np.searchsorted(self.keys, keys), 0, len(self.keys) - 1)
        found = self.keys[i] == keys
        return np.where(found, self.t[i], 0.0), found


def _parse_times(lines: Iterable[str], p: Path) -> KeyframeTimes:
    keys, times = array("Q"), array("d")
    for n, line in enumerate(lines, start=1):
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        try:
            rid, idx, ns = int(parts[0]), int(parts[1]), int(parts[2])
        except (ValueError, IndexError):
            raise line_error(p, n, "a timestamps line is 'robot_id keyframe_index time_ns' (whole numbers)") from None
        if rid < 0 or idx < 0 or ns < 0:
            raise line_error(p, n, "robot_id, keyframe_index and time_ns must be >= 0")
        if rid > 255 - ord("a") or idx > _SYMBOL_INDEX or ns > MAX_TIME_S * 1e9:
            raise line_error(
                p,
                n,
                f"robot_id at most {255 - ord('a')}, keyframe_index below 2^56 and time_ns at most "
                f"{MAX_TIME_S * 1e9:g} (a gtsam Symbol key and a time)",
            )
        keys.append(((ord("a") + rid) << 56) | idx)
        times.append(ns / 1e9)
    k = np.frombuffer(keys, dtype=np.uint64)
    order = np.argsort(k, kind="stable")
    k, t = k[order], np.frombuffer(times, dtype=np.float64)[order]
    last = np.append(k[1:] != k[:-1], True)  # the last line of a key listed twice
    return KeyframeTimes(k[last], t[last])


def read_times_file(path: str | Path) -> KeyframeTimes:
    """The keyframe times of a g2o timestamps file (``robot_id index time_ns ...`` a line), streamed."""
    return read_stream(path, "timestamps file", _parse_times)


def _symbols(keys: NDArray[np.uint64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(robot id, index) of gtsam Symbol keys (character ``'a' + id`` in the top 8 bits)."""
    return (keys >> np.uint64(56)).astype(np.int64) - ord("a"), (keys & np.uint64(_SYMBOL_INDEX)).astype(np.int64)


def _text_key(part: str) -> int | None:
    """The gtsam Symbol key of a key written as text, ``a12`` (a letter and an index), else None."""
    if len(part) < 2 or not ("a" <= part[0] <= "z") or not part[1:].isdigit() or int(part[1:]) > _SYMBOL_INDEX:
        return None
    return (ord(part[0]) << 56) | int(part[1:])


def _edge_keys(p: Path, n: int, parts: list[str], text: bool) -> tuple[int, int]:
    """The two keys of an edge: whole numbers (gtsam Symbol keys), or with ``text`` letter-and-index keys
    (``a12 b34``, the reference's per-pair files) as the Symbol keys they name."""
    if text:
        keys = [_text_key(k) for k in parts[1:3]]
        if keys[0] is None or keys[1] is None:
            raise line_error(p, n, f"{EDGE}: keys are a<index> and b<index> in this file, got {parts[1]} {parts[2]}")
        return keys[0], keys[1]
    if not (parts[1].isdigit() and parts[2].isdigit()):
        raise line_error(p, n, f"{EDGE}: keys must be whole numbers (gtsam Symbol keys), got {parts[1]} {parts[2]}")
    k1, k2 = int(parts[1]), int(parts[2])
    if k1 >= 1 << 64 or k2 >= 1 << 64:
        raise line_error(p, n, f"{EDGE}: keys must be below 2^64 (gtsam Symbol keys), got {parts[1]} {parts[2]}")
    return k1, k2


def _edge_line(p: Path, n: int, parts: list[str], text: bool = False) -> tuple[int, int, list[float]]:
    """The keys and pose of an ``EDGE_SE3:QUAT`` line, checked."""
    if len(parts) != 10 + _INFO:
        raise line_error(
            p,
            n,
            f"{EDGE} needs key1 key2 x y z qx qy qz qw and {_INFO} information entries "
            f"({9 + _INFO} values), got {len(parts) - 1}",
        )
    k1, k2 = _edge_keys(p, n, parts, text)
    vals = parse_floats(p, n, parts[3:], EDGE)
    check_pose(p, n, vals[:7])
    for k, v in enumerate(vals[7:], start=1):
        bad = field_problem(f"information entry {k}", v)
        if bad is not None:
            raise line_error(p, n, bad)
    return k1, k2, vals[:7]


def _first_keys(lines: Iterable[str], p: Path) -> tuple[str, str] | None:
    for line in lines:
        parts = line.split()
        if len(parts) >= 3 and parts[0] == EDGE:
            return parts[1], parts[2]
    return None


def first_edge_keys(path: str | Path) -> tuple[str, str] | None:
    """The two keys of a g2o file's first edge as written (None: it has no edge)."""
    return read_stream(path, "closure file", _first_keys)


def _is_odometry(k1: int, k2: int) -> bool:
    """Whether an edge joins keyframes k and k + 1 of one robot."""
    return k1 >> 56 == k2 >> 56 and (k2 & _SYMBOL_INDEX) == (k1 & _SYMBOL_INDEX) + 1


def scan_g2o(
    lines: Iterable[str], p: Path, text_keys: bool = False
) -> tuple[array[int], array[float], array[int], array[int]]:
    """Check every line of a g2o file; its loop-closure edges in file order: keys (2 a row, gtsam Symbol
    keys; ``text_keys``: written ``a12``), poses (7 a row), scores (-1: none) and lines. Odometry edges
    are checked and dropped."""
    keys, poses, scores, where = array("Q"), array("d"), array("q"), array("q")
    pending = None
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
                    raise line_error(p, n, "'# LC: n' needs a whole number of associations") from None
            continue
        if parts[0] == VERTEX:
            if len(parts) != 9:
                raise line_error(p, n, f"{VERTEX} needs key x y z qx qy qz qw (8 values), got {len(parts) - 1}")
            vals = parse_floats(p, n, parts[1:], VERTEX)
            bad = field_problem("key", vals[0]) or pose_problem(_POSE, vals[1:])
            if bad is not None:
                raise line_error(p, n, bad)
        elif parts[0] == EDGE:
            k1, k2, pose = _edge_line(p, n, parts, text_keys)
            if pending is not None or not _is_odometry(k1, k2):
                keys.extend((k1, k2))
                poses.extend(pose)
                scores.append(-1 if pending is None else pending)
                where.append(n)
            pending = None
        else:
            raise line_error(p, n, f"unsupported tag {parts[0]!r} (allowed: {VERTEX}, {EDGE}, '#' comments)")
    return keys, poses, scores, where


def parse_g2o_closures(
    lines: Iterable[str],
    source: str | Path,
    times: KeyframeTimes,
    robots: Sequence[str],
    quaternion_order: QuaternionOrder = "xyzw",
) -> ClosureSet:
    """Loop closures of g2o lines, read one line at a time from any iterable; robots and times from the keys.

    Args:
        lines: the g2o file's lines (a file, a pipe, a generator).
        source: the file's name in errors.
        times: ``read_times_file`` of its timestamps file.
        robots: robot names in key order (Symbol character ``'a' + i`` is ``robots[i]``).
        quaternion_order: the order of each edge's four quaternion numbers.
    """
    p = Path(source)
    keys, poses, scores, where = scan_g2o(lines, p)
    k = np.frombuffer(keys, dtype=np.uint64).reshape(-1, 2)
    line = np.frombuffer(where, dtype=np.int64).copy()
    rid, idx = _symbols(k)
    t, found = times.lookup(k)
    bad_robot = (rid < 0) | (rid >= len(robots))
    failed = bad_robot | ~found
    if failed.any():  # the first failing end in file order, a's before b's, the robot before its time
        row = int(np.flatnonzero(failed.any(axis=1))[0])
        end = int(np.flatnonzero(failed[row])[0])
        r, i = int(rid[row, end]), int(idx[row, end])
        if bad_robot[row, end]:
            letters = ", ".join(f"'{chr(ord('a') + j)}' ({name})" for j, name in enumerate(robots))
            raise line_error(
                p, int(line[row]), f"key of Symbol character {chr(ord('a') + r)!r}: no such robot (allowed: {letters})"
            )
        raise line_error(
            p, int(line[row]), f"keyframe {i} of robot {robots[r]} (id {r}) has no time in the timestamps file"
        )
    return ClosureSet(
        tuple(robots),
        rid[:, 0].copy(),
        t[:, 0].copy(),
        rid[:, 1].copy(),
        t[:, 1].copy(),
        np_poses(np.frombuffer(poses, dtype=np.float64).reshape(-1, 7), quaternion_order),
        np.frombuffer(scores, dtype=np.int64).copy(),
        line,
    )


def read_g2o_closures(
    path: str | Path, times: KeyframeTimes, robots: Sequence[str], quaternion_order: QuaternionOrder = "xyzw"
) -> ClosureSet:
    """Loop closures of a g2o file (``parse_g2o_closures``), streamed."""
    return read_stream(path, "closure file", parse_g2o_closures, times, robots, quaternion_order)


def read_closures(
    path: str | Path,
    times: str | Path | None = None,
    robots: Sequence[str] | None = None,
    *,
    quaternion_order: QuaternionOrder = "xyzw",
) -> ClosureSet:
    """Closures of a ``.csv`` or ``.g2o`` file (a g2o file needs its timestamps file and the robot order);
    ``quaternion_order``: the order of the file's quaternion numbers."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"--closures {p}: no such file")
    if p.suffix.lower() == ".csv":
        return read_csv_closures(p, quaternion_order)
    if p.suffix.lower() == ".g2o":
        if times is None:
            raise ConfigError(f"--closures {p}: a g2o file needs its timestamps file (--times)")
        if not robots:
            raise ConfigError(f"--closures {p}: a g2o file needs the robot order (--robots)")
        return read_g2o_closures(p, read_times_file(times), robots, quaternion_order)
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
