"""Fixtures of the visual tests: a renderer of the textured world at 320 x 240 (noise-free depth)."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align.visual.features import (
    KeyframeFeatures,
    OrbParams,
    extract_features,
    make_orb,
)
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.render import SensorRenderer

from .textured_world import build_textured_world, camera_pose

CAM = CameraConfig(width=320, height=240)


class Shooter:
    """Renders the textured world (seed given) and extracts ORB features with depth."""

    def __init__(self, seed: int) -> None:
        self.renderer = SensorRenderer(build_textured_world(seed), CAM, rgb=True)
        self.orb = make_orb(OrbParams())
        self.K = CAM.intrinsics()

    def frame(self, x: float, y: float, yaw_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(T_world_cam, rgb, depth) of a level camera at (x, y) with heading ``yaw_deg``."""
        T = camera_pose(x, y, np.radians(yaw_deg))
        rgb, depth, _ = self.renderer.render(T)
        assert rgb is not None
        return T, rgb, depth

    def features(self, x: float, y: float, yaw_deg: float) -> tuple[np.ndarray, KeyframeFeatures]:
        T, rgb, depth = self.frame(x, y, yaw_deg)
        return T, extract_features(rgb, depth, self.K, self.orb)


@pytest.fixture(scope="package")
def shooter():
    s = Shooter(0)
    yield s
    s.renderer.close()


@pytest.fixture(scope="package")
def other_shooter():
    s = Shooter(1)
    yield s
    s.renderer.close()
