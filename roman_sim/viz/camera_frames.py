"""Camera frames of a finished run for the view: from its recordings, else re-rendered.

A robot read from a TUM RGB-D folder is read from it again. A simulated robot's frames are
kept only when its scenario sets ``record_frames`` (``recordings/<robot>``);
otherwise a subsample of each robot's frames is rendered again along the same planned
trajectory (same world, paths and poses; RGB is rendered for the view even when the run
did not, and the depth noise differs from the run's, since fewer frames draw from it).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from roman_sim.core.sensors import Frame

if TYPE_CHECKING:
    from roman_sim.interop.tum_reader import TumSourceConfig
    from roman_sim.pipeline.scenario import Scenario, ScenarioRobot
    from roman_sim.sim.robot import Path2D
    from roman_sim.world import World

log = logging.getLogger(__name__)


def subsample(n: int, max_images: int) -> np.ndarray:
    """At most ``max_images`` evenly spaced indices of ``range(n)`` (first and last kept)."""
    if max_images <= 0 or n == 0:
        return np.zeros(0, dtype=np.int64)
    if n <= max_images:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_images)).astype(np.int64))


def _recorded(rec_dir: Path, max_images: int) -> Iterator[Frame]:
    from roman_sim.sim.recording import read_recording, recording_info

    keep = set(subsample(int(recording_info(rec_dir)["frame_count"]), max_images).tolist())
    for k, frame in enumerate(read_recording(rec_dir)):
        if k in keep:
            yield frame


def _sequence(source: TumSourceConfig, robot: str, seed: int, max_images: int) -> Iterator[Frame]:
    from roman_sim.interop.tum_reader import TumSequence

    seq = TumSequence(source, robot=robot, seed=seed)
    yield from seq.frames(subsample(len(seq), max_images).tolist())


def _rendered(
    world: World, scenario: Scenario, cfg: ScenarioRobot, paths: dict[str, Path2D], max_images: int
) -> Iterator[Frame]:
    from dataclasses import replace

    from roman_sim.sim.robot import DrivenRun, render_trajectory, trajectory_along

    t, T_wb, T_ob = trajectory_along(world, cfg, scenario.seed, paths[cfg.name])
    idx = subsample(len(t), max_images)
    cfg_rgb = cfg.model_copy(update={"render_rgb": True})
    for k, frame in zip(idx, render_trajectory(world, cfg_rgb, scenario.seed, DrivenRun(t[idx], T_wb[idx], T_ob[idx]))):
        yield replace(frame, index=int(k))


def camera_frames(
    run_dir: Path, scenario: Scenario, world: World | None, max_images: int
) -> dict[str, Iterator[Frame]]:
    """Per robot, a lazy stream of at most ``max_images`` frames (recorded or re-rendered).

    Robots without a recording are re-rendered only when ``world`` is given.
    """
    out: dict[str, Iterator[Frame]] = {}
    paths = None
    for cfg in scenario.robots:
        rec_dir = run_dir / "recordings" / cfg.name
        source = getattr(cfg, "source", None)  # a plain RobotConfig has none
        if source is not None:
            out[cfg.name] = _sequence(source, cfg.name, scenario.seed, max_images)
            continue
        if (rec_dir / "meta.json").is_file():
            out[cfg.name] = _recorded(rec_dir, max_images)
            continue
        if world is None:
            log.info("robot %s: no recording and no world: no camera images", cfg.name)
            continue
        if paths is None:
            from roman_sim.sim.robot import plan_paths

            paths = plan_paths(world, scenario.robots, scenario.seed)
        out[cfg.name] = _rendered(world, scenario, cfg, paths, max_images)
    return out
