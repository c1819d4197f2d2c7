"""docs/interop.md: the camera figures it states, recomputed from the camera model."""

from __future__ import annotations

import math
import re
from pathlib import Path

from roman_sim.sim.camera import CameraConfig

PAGE = Path(__file__).resolve().parent.parent / "docs" / "interop.md"


def test_camera_pixel_figures() -> None:
    text = PAGE.read_text(encoding="utf-8")
    m = re.search(r"fx = ([\d.]+) and fy = ([\d.]+) at (\d+) x (\d+)", text)
    assert m is not None
    w, h = int(m[3]), int(m[4])
    k = CameraConfig(width=w, height=h).intrinsics()
    assert (float(m[1]), float(m[2])) == (round(k.fx, 1), round(k.fy, 1))
    assert k.fx != k.fy  # the default's pixels are not square
    square = CameraConfig(width=w, height=h, vfov_deg=None).intrinsics()
    assert square.fx == square.fy
    vfov = math.degrees(2 * math.atan((h / 2) / square.fy))
    (about,) = re.findall(r"about (\d+) deg at 4:3", text)
    assert w * 3 == h * 4 and round(vfov) == int(about)
    defaults = CameraConfig()
    assert f"hfov_deg: {defaults.hfov_deg:g}, vfov_deg: {defaults.vfov_deg:g}" in text
