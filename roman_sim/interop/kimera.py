"""Kimera-Multi's loop closures (``loop_closures.csv``), read with the keyframe times beside them.

Kimera-Multi's distributed loop closure node (``MIT-SPARK/Kimera-Distributed``,
``DistributedLoopClosure::createLogFiles``) writes into each robot's log folder (by default
``logs/kimera<robot_id>/``):

- ``loop_closures.csv``: ``robot1,pose1,robot2,pose2,qx,qy,qz,qw,tx,ty,tz,norm_bow_score,
  mono_inliers,stereo_inliers,stamp_ns``, one closure a line: robot indices, keyframe ids,
  and ``T_src_dst`` (keyframe ``pose2`` of ``robot2`` in keyframe ``pose1`` of ``robot1``,
  body frames: the edge ``roman_sim.interop.closures`` reads), then the place-recognition
  score, the inlier counts of its two geometric checks and ``stamp_ns``, the wall time of
  the detection (not a keyframe's time).
- ``odometry_poses.csv``: ``stamp_ns,robot_index,pose_index,qx,qy,qz,qw,tx,ty,tz``, each
  keyframe of the robot with its sensor stamp (ns) and odometry pose.

A closure's keyframe ids are turned into times through the ``odometry_poses.csv`` files
(those that Kimera-Multi writes: each lists its robot's keyframes; its inter-robot closures
name the other robots' keyframes, so their files are needed too): by default every
``odometry_poses.csv`` under the closure file's folder (a closure file given alone, in its
robot's folder, finds its own robot's keyframes; the log root finds every robot's), or
those under ``times`` (a file or a folder). Robot index ``i`` is the ``i``-th robot of the
robot order. A folder of closures reads every ``loop_closures.csv`` under it (lines
numbered as one text, see ``ClosureSet.files``). The closures carry no association count:
each is one Kimera-Multi accepted after its geometric checks, so each counts as accepted
(the figures of one operating point); its inlier counts are on another scale and are not
used as scores.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable, Sequence
from pathlib import Path

from roman_sim.core.errors import ConfigError
from roman_sim.core.tum import field_problem
from roman_sim.interop.closures import (
    ClosureRows,
    ClosureSet,
    QuaternionOrder,
    check_pose,
    line_error,
    parse_floats,
    read_stream,
)

LC_CSV, ODOM_CSV = "loop_closures.csv", "odometry_poses.csv"
LC_FIELDS = "robot1,pose1,robot2,pose2,qx,qy,qz,qw,tx,ty,tz,norm_bow_score,mono_inliers,stereo_inliers,stamp_ns".split(
    ","
)
ODOM_FIELDS = "stamp_ns,robot_index,pose_index,qx,qy,qz,qw,tx,ty,tz".split(",")
_KEY_NAMES = ("x", "y", "z", "qx", "qy", "qz", "qw")


def first_row(path: Path) -> list[str]:
    """The cells of a CSV file's first line (empty for an empty file)."""

    def parse(lines: Iterable[str], p: Path) -> list[str]:
        for row in csv.reader(lines):
            return [c.strip() for c in row]
        return []

    return read_stream(path, "closure file", parse)


def _ints(p: Path, n: int, cells: Sequence[str], names: Sequence[str]) -> list[int]:
    """Whole numbers >= 0 (ConfigError naming the field otherwise)."""
    out = []
    for c, name in zip(cells, names):
        if not c.isdigit():
            raise line_error(p, n, f"field {name}: {c!r} is not a whole number >= 0")
        out.append(int(c))
    return out


def _robot(p: Path, n: int, index: int, robots: Sequence[str], what: str) -> str:
    if index >= len(robots):
        allowed = ", ".join(f"{i} ({r})" for i, r in enumerate(robots))
        raise line_error(p, n, f"{what} {index} is no robot of the run (allowed: {allowed})")
    return robots[index]


def _parse_odometry(lines: Iterable[str], p: Path, robots: Sequence[str], out: dict[tuple[int, int], int]) -> None:
    """Each keyframe's stamp (ns) into ``out``, by ``(robot index, keyframe id)``."""
    for n, row in enumerate(csv.reader(lines), start=1):
        cells = [c.strip() for c in row]
        if n == 1:
            if cells != ODOM_FIELDS:
                raise line_error(p, n, f"a Kimera-Multi {ODOM_CSV} starts with the header {','.join(ODOM_FIELDS)}")
            continue
        if not any(cells):
            continue
        if len(cells) != len(ODOM_FIELDS):
            raise line_error(p, n, f"{len(cells)} fields; a keyframe line is {','.join(ODOM_FIELDS)}")
        ns, rid, kf = _ints(p, n, cells[:3], ODOM_FIELDS[:3])
        _robot(p, n, rid, robots, "robot_index")
        out[(rid, kf)] = ns


def _parse_closures(
    lines: Iterable[str],
    p: Path,
    robots: Sequence[str],
    stamps: dict[tuple[int, int], int],
    order: QuaternionOrder,
    base: Path,
) -> ClosureSet:
    rows = ClosureRows()
    for r in robots:
        rows.code(r)
    for n, row in enumerate(csv.reader(lines), start=1):
        cells = [c.strip() for c in row]
        if n == 1:
            if cells != LC_FIELDS:
                raise line_error(p, n, f"a Kimera-Multi {LC_CSV} starts with the header {','.join(LC_FIELDS)}")
            continue
        if not any(cells):
            continue
        if len(cells) != len(LC_FIELDS):
            raise line_error(p, n, f"{len(cells)} fields; a closure line is {','.join(LC_FIELDS)}")
        r1, k1, r2, k2 = _ints(p, n, cells[:4], LC_FIELDS[:4])
        v = parse_floats(p, n, cells[4:11], "relative pose")
        pose = [*v[4:7], *v[0:4]]  # x y z and the quaternion's four numbers
        check_pose(p, n, pose, _KEY_NAMES)
        bad = field_problem(LC_FIELDS[11], parse_floats(p, n, cells[11:12], LC_FIELDS[11])[0])
        if bad is not None:
            raise line_error(p, n, bad)
        _ints(p, n, cells[12:], LC_FIELDS[12:])
        ends = []
        for rid, kf in ((r1, k1), (r2, k2)):
            robot = _robot(p, n, rid, robots, "robot index")
            if (rid, kf) not in stamps:
                raise line_error(
                    p,
                    n,
                    f"keyframe {kf} of robot {robot} (index {rid}) has no time in the {ODOM_CSV} files under {base} "
                    "(each robot writes its own: give a folder holding every robot's with --times)",
                )
            ends.append((robot, stamps[(rid, kf)] / 1e9))
        rows.add(ends[0][0], ends[0][1], ends[1][0], ends[1][1], pose, None, n)
    return rows.done(order)


def _files(path: Path, name: str) -> list[Path]:
    return [path] if path.is_file() else sorted(path.rglob(name))


def read_kimera(
    path: str | Path,
    robots: Sequence[str],
    times: str | Path | None = None,
    quaternion_order: QuaternionOrder = "xyzw",
) -> ClosureSet:
    """Kimera-Multi's closures of a ``loop_closures.csv`` or a folder of them (module docstring).

    Args:
        path: a ``loop_closures.csv``, or a folder searched for them.
        robots: robot names by Kimera-Multi's robot index.
        times: an ``odometry_poses.csv`` or a folder searched for them (default: the closure
            file's folder, or the folder given).
        quaternion_order: the order of the quaternion's four fields.
    """
    p = Path(path)
    found = _files(p, LC_CSV)
    if not found:
        raise ConfigError(f"--closures {p}: no {LC_CSV} in the folder (Kimera-Multi's log folders)")
    base = Path(times) if times is not None else (p if p.is_dir() else p.parent)
    odometry = _files(base, ODOM_CSV)
    if not odometry:
        raise ConfigError(
            f"{base}: no {ODOM_CSV} (Kimera-Multi's keyframe times, written beside {LC_CSV}; give them with --times)"
        )
    stamps: dict[tuple[int, int], int] = {}
    for f in odometry:
        read_stream(f, "keyframe file", _parse_odometry, robots, stamps)
    parts = []
    for f in found:
        cs = read_stream(f, "closure file", _parse_closures, robots, stamps, quaternion_order, base)
        with f.open("rb") as fh:
            parts.append((cs, str(f.relative_to(p)) if p.is_dir() else str(f), sum(1 for _ in fh)))
    return parts[0][0] if len(parts) == 1 and not p.is_dir() else ClosureSet.concat(parts)
