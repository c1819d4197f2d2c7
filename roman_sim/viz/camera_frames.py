"""Camera frames of a finished run for the view: from its recordings, else re-rendered.

Each robot is a ``FrameSource``: its recording (``recordings/<robot>``, kept when its scenario
sets ``record_frames``), else the robot opened as the maps stage opens it
(``roman_sim.pipeline.stages.maps_input.open_robot``): a robot read from a TUM RGB-D folder
is read from it again, a simulated one rendered again along the same planned trajectory
(same world, paths and poses; RGB is rendered for the view even when the run did not, and
the depth noise differs from the run's, since fewer frames draw from it).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from roman_sim.core.errors import RomanSimError
from roman_sim.core.sensors import Frame, FrameSource

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import Scenario
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
    """Per robot, a lazy stream of at most ``max_images`` frames (recorded, read again or re-rendered).

    A robot without a recording is opened as the maps stage opens it (``open_robot``), with RGB on
    every frame; one that cannot be (a simulated robot when ``world`` is None) has no images.
    """
    from roman_sim.pipeline.context import RunContext
    from roman_sim.pipeline.stages.maps_input import open_robot
    from roman_sim.sim.recording import Recording

    ctx = RunContext(scenario, run_dir)
    sources: dict[str, FrameSource] = {}
    for cfg in scenario.robots:
        rec_dir = run_dir / "recordings" / cfg.name  # only a simulated robot of a run with record_frames has one
        try:
            sources[cfg.name] = (
                Recording(rec_dir) if (rec_dir / "meta.json").is_file() else open_robot(ctx, cfg, lambda: world).rgb
            )
        except RomanSimError as err:
            log.info("robot %s: no camera images (%s)", cfg.name, err)
    return {name: src.frames(subsample(len(src), max_images).tolist()) for name, src in sources.items()}
