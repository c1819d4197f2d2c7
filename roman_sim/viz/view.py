"""A 3D view of a finished run as a rerun recording (``.rrd``), see ``rerun_log`` for the tree.

The world is generated again from the run's ``config.yaml`` (deterministic in the seed)
for the objects, the terrain and re-rendered camera frames. Truth and odometry trajectories
are shown as the run wrote them (odometry placed at the true start); the pose-graph
trajectories (in the first robot's odometry frame) are moved into the world by the single
SE(3) alignment of all robots used for the ATE. Segment maps sit in each robot's odometry
frame placed the same way as its odometry (``gravity_aligned(T_world_body[0])``).
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import RomanSimError, StorageError
from roman_sim.core.geometry import gravity_aligned
from roman_sim.viz import rerun_log as rl
from roman_sim.viz.run_folder import RunFolder, load_run_folder

if TYPE_CHECKING:
    from rerun import RecordingStream

    from roman_sim.core.trajectory import Trajectory
    from roman_sim.interop.objects import ObjectRow
    from roman_sim.mapping.mapper import SegmentMap
    from roman_sim.world import World

log = logging.getLogger(__name__)

APPLICATION_ID = "roman_sim"
PLAIN_VARIANTS = ("truth", "odometry")
F64 = NDArray[np.float64]


@dataclass
class ViewResult:
    """What ``write_run_view`` wrote."""

    path: Path
    images: dict[str, int] = field(default_factory=dict)
    closures: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def _aligned_trajectories(rf: RunFolder, notes: list[str]) -> dict[str, dict[str, Trajectory]]:
    from roman_sim.core.errors import EvaluationError
    from roman_sim.evaluation.ate import multi_robot_ate

    out = {r: {v: tr for v, tr in vs.items() if v in PLAIN_VARIANTS} for r, vs in rf.trajectories.items()}
    truth = {r: vs["truth"] for r, vs in rf.trajectories.items() if "truth" in vs}
    variants = sorted({v for vs in rf.trajectories.values() for v in vs} - set(PLAIN_VARIANTS))
    for variant in variants:
        est = {r: vs[variant] for r, vs in rf.trajectories.items() if variant in vs and r in truth}
        try:
            res = multi_robot_ate(est, truth, "se3")["all"] if est else None
        except EvaluationError as err:
            res = None
            log.debug("%s: %s", variant, err)
        if res is None:
            notes.append(f"trajectories {variant}: not aligned to the truth (not shown)")
            continue
        for r, tr in est.items():
            out[r][variant] = tr.transformed(res.T_align)
    return out


def _T_world_odom(smap: SegmentMap) -> np.ndarray:
    T = getattr(smap, "T_world_body", None)
    return gravity_aligned(T[0]) if T is not None and len(T) else np.eye(4)


def _closure_lines(rf: RunFolder, T_wo: dict[str, np.ndarray]) -> dict[str, list[tuple[F64, F64]]]:
    lines: dict[str, list[tuple[F64, F64]]] = {"correct": [], "wrong": [], "rejected": []}
    for c in rf.closures:
        ends = []
        for name in (c.a, c.b):
            s = rf.submap(name)
            T = s.truth.T_world_submap if s.truth is not None else T_wo.get(s.robot, np.eye(4)) @ s.T_odom_submap
            ends.append(np.asarray(T, dtype=np.float64)[:3, 3])
        verdict = "rejected" if c.accepted is False else ("correct" if c.correct else "wrong")
        lines[verdict].append((ends[0], ends[1]))
    return lines


def _world(rf: RunFolder, notes: list[str]) -> World | None:
    from roman_sim.world import generate

    if not rf.scenario.needs_world:
        return None
    try:
        return generate(rf.scenario.world.spec(), rf.scenario.seed)
    except RomanSimError as err:
        notes.append(f"world not regenerated ({err}): no objects, terrain or re-rendered images")
        return None


def _object_rows(rf: RunFolder, world: World | None) -> list[ObjectRow]:
    """The world's objects, else those of the recorded sequences' object tables (first one found)."""
    from roman_sim.interop.objects import object_rows, read_object_table
    from roman_sim.pipeline.stages.maps_sources import object_tables

    if world is not None:
        return object_rows(world.truth)
    tables = object_tables(rf.scenario.robots)
    return read_object_table(tables[0]) if tables else []


def _log_images(
    rec: RecordingStream, rf: RunFolder, world: World | None, max_images: int, T_wo: dict[str, np.ndarray]
) -> dict[str, int]:
    from roman_sim.viz.camera_frames import camera_frames

    counts = {}
    for robot, frames in camera_frames(rf.path, rf.scenario, world, max_images).items():
        n = 0
        for frame in frames:
            T_wb = (
                frame.truth.T_world_body if frame.truth is not None else T_wo.get(robot, np.eye(4)) @ frame.T_odom_body
            )
            rl.log_camera(rec, robot, frame, np.asarray(T_wb) @ frame.T_body_cam, first=n == 0)
            n += 1
        counts[robot] = n
    return counts


def write_run_view(run_dir: str | Path, out: str | Path | None = None, max_images: int = 60) -> ViewResult:
    """Write the rerun recording of a finished run (default ``<run>/view.rrd``).

    Args:
        run_dir: a run folder of ``roman-sim run``.
        out: recording path (written under a temporary name, then renamed).
        max_images: camera frames per robot on the timeline (0: none).
    """
    import rerun as rr

    rf = load_run_folder(run_dir)
    path = Path(out) if out is not None else rf.path / "view.rrd"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    result = ViewResult(path)
    sc = rf.scenario
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=f"{sc.name}-seed{sc.seed}", send_properties=False)
    try:
        rec.save(tmp)
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        world = _world(rf, result.notes)
        if world is not None:
            rl.log_terrain(rec, world.truth.terrain)
        rl.log_objects(rec, _object_rows(rf, world))
        rl.log_trajectories(rec, _aligned_trajectories(rf, result.notes))
        T_wo = {r: _T_world_odom(m) for r, m in rf.maps.items()}
        for robot, smap in rf.maps.items():
            rl.log_segment_map(rec, robot, smap, T_wo[robot])
        for robot, subs in rf.submaps.items():
            rl.log_submaps(rec, robot, subs, T_wo.get(robot, np.eye(4)))
        lines = _closure_lines(rf, T_wo)
        rl.log_closures(rec, lines)
        result.closures = {k: len(v) for k, v in lines.items()}
        result.images = _log_images(rec, rf, world, max_images, T_wo) if max_images > 0 else {}
        rec.flush()
        rec.disconnect()
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return result


def open_viewer(path: str | Path) -> bool:
    """Open the recording in rerun's viewer when a display exists; False when there is none."""
    p = Path(path)
    if not p.is_file():
        raise StorageError(f"{p}: recording not found")
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    subprocess.Popen(
        [sys.executable, "-m", "rerun", str(p)],
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    return True
