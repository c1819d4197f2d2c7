"""Test scenes for the mapping tests (frames come from ``roman_sim.mapping.synthetic``)."""

from __future__ import annotations

import numpy as np

from roman_sim.mapping import synthetic
from roman_sim.mapping.synthetic import T_BODY_CAM, frame_at

INTR = synthetic.intrinsics(160, 120, hfov_deg=2 * np.degrees(np.arctan(80 / 80.0)))
SPHERES = [(np.array([5.0, 1.0, 0.6]), 0.6), (np.array([6.0, -1.5, 0.8]), 0.8), (np.array([4.0, -0.2, 0.4]), 0.4)]

__all__ = ["INTR", "SPHERES", "T_BODY_CAM", "drive", "frame_at"]


def drive(spheres=SPHERES, n: int = 12, T_odom_world=None):
    """Frames of a robot driving along +x from the origin at 1 m/s, 6 Hz."""
    return synthetic.drive(spheres, n=n, T_odom_world=T_odom_world, intr=INTR)
