"""Keyframes chosen from the trajectory alone (``keyframe_mask``) against the extractor fed every frame."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align.visual import KeyframeExtractor, KeyframeParams, default_vocabulary
from roman_sim.align.visual.keyframes import keyframe_mask
from roman_sim.core.errors import MappingError
from roman_sim.core.geometry import pose_4dof
from roman_sim.core.sensors import Frame, Intrinsics

K = Intrinsics(16, 12, 10.0, 10.0, 7.5, 5.5)


def _odometry(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Times and odometry poses of a robot that drives, turns on the spot and stops."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.1, 0.5, n))
    x = np.cumsum(rng.choice([0.0, 0.1, 0.35], n))  # stops (every_s decides), walks and runs
    yaw = np.cumsum(rng.choice([0.0, 0.0, np.radians(7.0)], n))
    return t, np.stack([pose_4dof(x[i], 0.5 * x[i], 0.0, yaw[i]) for i in range(n)])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mask_makes_the_extractors_choices(seed: int) -> None:
    t, T = _odometry(80, seed)
    params = KeyframeParams(every_m=1.0, every_deg=15.0, every_s=5.0)
    ex = KeyframeExtractor(default_vocabulary(), params)
    rgb, depth = np.zeros((12, 16, 3), np.uint8), np.ones((12, 16), np.float32)
    chosen = [ex.offer(Frame("r", i, float(t[i]), rgb, depth, T[i], np.eye(4), K)) is not None for i in range(len(t))]
    mask = keyframe_mask(t, T, params)
    assert mask.tolist() == chosen
    assert mask[0] and 10 < mask.sum() < len(t) - 10  # moves, turns and waits all make keyframes


def test_only_keyframes_need_rgb() -> None:
    t, T = _odometry(30, 3)
    mask = keyframe_mask(t, T)
    ex = KeyframeExtractor(default_vocabulary())
    depth = np.ones((12, 16), np.float32)
    for i in range(len(t)):
        rgb = np.zeros((12, 16, 3), np.uint8) if mask[i] else None
        assert (ex.offer(Frame("r", i, float(t[i]), rgb, depth, T[i], np.eye(4), K)) is not None) == mask[i]
    with pytest.raises(MappingError, match="render_rgb"):  # a frame that is due and has no RGB
        KeyframeExtractor(default_vocabulary()).offer(Frame("r", 0, 0.0, None, depth, T[0], np.eye(4), K))
