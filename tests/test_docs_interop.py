"""docs/interop.md: the camera figures it states, recomputed from the camera model."""

from __future__ import annotations

import math
import re
from pathlib import Path

from roman_sim.sim.camera import PIXEL_ASPECT, CameraConfig

PAGE = Path(__file__).resolve().parent.parent / "docs" / "interop.md"


def test_camera_pixel_figures() -> None:
    text = " ".join(PAGE.read_text(encoding="utf-8").split())
    defaults = CameraConfig()
    assert defaults.vfov_deg is None and f"camera: {{hfov_deg: {defaults.hfov_deg:g}, vfov_deg: null}}" in text
    m = re.search(r"2 atan\(tan\(([\d.]+) deg\) \* 3 / 4\) = ([\d.]+) deg: fx = fy = ([\d.]+) at (\d+) x (\d+)", text)
    assert m is not None
    assert float(m[1]) == defaults.hfov_deg / 2
    w, h = int(m[4]), int(m[5])
    k = CameraConfig(width=w, height=h).intrinsics()
    assert w * 3 == h * 4 and k.fx == k.fy and float(m[3]) == round(k.fx, 1)
    assert float(m[2]) == round(k.fov_deg[1], 1) == round(defaults.intrinsics().fov_deg[1], 1)
    # the D455's 87 x 58 deg at 16:9 with square pixels, and the stretch 58 deg would need at 4:3
    wide = CameraConfig(width=1280, height=720).intrinsics()
    assert f"square pixels give {wide.fov_deg[1]:.1f} deg vertical" in text
    d455 = CameraConfig(width=w, height=h, vfov_deg=58.0).intrinsics()
    assert f"(fy / fx = {d455.fy / d455.fx:.2f})" in text
    assert f"vfov_deg: 58}} # fx {d455.fx:.1f}, fy {d455.fy:.1f}" in text
    assert f"must lie in {PIXEL_ASPECT[0]:g} to {PIXEL_ASPECT[1]:g}" in text
    assert math.isclose(k.fov_deg[0], defaults.hfov_deg)
