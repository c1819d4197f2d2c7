"""Camera frames of a finished run for the view: from its recordings, else re-rendered.

Each robot is a ``FrameSource`` (``roman_sim.sim.source.robot_sources``): a robot read from a
TUM RGB-D folder is read from it again. A simulated robot's frames are
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

from roman_sim.core.sensors import Frame, FrameSource

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import Scenario, ScenarioRobot
    from roman_sim.world import World

log = logging.getLogger(__name__)


def subsample(n: int, max_images: int) -> np.ndarray:
    """At most ``max_images`` evenly spaced indices of ``range(n)`` (first and last kept)."""
    if max_images <= 0 or n == 0:
        return np.zeros(0, dtype=np.int64)
    if n <= max_images:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_images)).astype(np.int64))


def camera_frames(
    run_dir: Path, scenario: Scenario, world: World | None, max_images: int
) -> dict[str, Iterator[Frame]]:
    """Per robot, a lazy stream of at most ``max_images`` frames (recorded or re-rendered).

    Robots without a recording are re-rendered only when ``world`` is given.
    """
    from roman_sim.sim.recording import Recording
    from roman_sim.sim.source import robot_sources

    def read_sequence(cfg: ScenarioRobot) -> FrameSource:
        from roman_sim.interop.tum_reader import TumSequence

        assert cfg.source is not None  # robot_sources opens only the robots that have one
        return TumSequence(cfg.source, robot=cfg.name, seed=scenario.seed)

    sources: dict[str, FrameSource] = {}
    opened = []
    for cfg in scenario.robots:
        rec_dir = run_dir / "recordings" / cfg.name
        if getattr(cfg, "source", None) is None and (rec_dir / "meta.json").is_file():
            sources[cfg.name] = Recording(rec_dir)
        elif getattr(cfg, "source", None) is not None or world is not None:
            opened.append(cfg.name)
        else:
            log.info("robot %s: no recording and no world: no camera images", cfg.name)
    if opened:
        for src in robot_sources(world, scenario.robots, scenario.seed, opened, rgb=True, open_recorded=read_sequence):
            sources[src.name] = src
    return {
        r.name: sources[r.name].frames(subsample(len(sources[r.name]), max_images).tolist())
        for r in scenario.robots
        if r.name in sources
    }
