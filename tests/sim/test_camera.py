"""Camera model: intrinsics, mount, projection / back-projection, invalid input."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import transform_points
from roman_sim.core.sensors import Intrinsics, backproject, check_intrinsics, project
from roman_sim.sim.camera import CameraConfig


def test_default_intrinsics_match_d455_with_square_pixels() -> None:
    """87 deg horizontal at 640 x 480, square pixels: the vertical field of view follows from 4:3."""
    k = CameraConfig().intrinsics()
    assert (k.width, k.height) == (640, 480)
    assert k.fx == k.fy and k.cx == 319.5 and k.cy == 239.5
    assert k.fx == pytest.approx(320.0 / np.tan(np.radians(43.5)))
    hfov, vfov = k.fov_deg
    assert hfov == pytest.approx(87.0, abs=1e-9)
    assert vfov == pytest.approx(np.degrees(2 * np.arctan(np.tan(np.radians(43.5)) * 0.75)), abs=1e-9)
    assert round(vfov, 1) == 70.9
    small = CameraConfig(width=160, height=120).intrinsics()
    assert small.fx == small.fy == pytest.approx(k.fx / 4)


def test_an_explicit_vertical_field_of_view_gives_non_square_pixels() -> None:
    k = CameraConfig(vfov_deg=58.0).intrinsics()
    assert k.fov_deg == pytest.approx((87.0, 58.0), abs=1e-9)
    assert k.fy / k.fx == pytest.approx(np.tan(np.radians(43.5)) * 0.75 / np.tan(np.radians(29.0)))
    assert CameraConfig(vfov_deg=None).intrinsics() == CameraConfig().intrinsics()


@pytest.mark.parametrize("vfov, aspect", [(10.0, "8.14"), (140.0, "0.259")])
def test_a_vertical_field_of_view_stretching_pixels_too_far_is_refused(vfov: float, aspect: str) -> None:
    with pytest.raises(ConfigError) as err:
        validate_model(CameraConfig, {"vfov_deg": vfov})
    msg = str(err.value)
    assert "\n" not in msg and f"vfov_deg ({vfov:g}) with hfov_deg 87 at 640 x 480" in msg
    assert f"aspect fy/fx {aspect}: allowed 0.5 to 2 (null: square pixels, 70.9 deg vertical)" in msg


def test_projection_backprojection_round_trip() -> None:
    k = CameraConfig(width=64, height=48).intrinsics()
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.5, 9.0, (48, 64)).astype(np.float32)
    depth[5, 7] = 0.0  # invalid pixel is skipped
    pts = backproject(depth, k)
    assert len(pts) == 64 * 48 - 1
    uv, front = project(k.K, pts)
    assert front.all()
    v, u = np.nonzero(depth > 0)
    np.testing.assert_allclose(uv, np.column_stack([u, v]), atol=1e-6)
    np.testing.assert_allclose(pts[:, 2], depth[depth > 0], rtol=1e-6)


def test_backproject_mask_and_points_behind() -> None:
    k = CameraConfig(width=16, height=12).intrinsics()
    depth = np.full((12, 16), 2.0, dtype=np.float32)
    mask = np.zeros((12, 16), dtype=bool)
    mask[3, 4] = True
    np.testing.assert_allclose(backproject(depth, k, mask), [[(4 - k.cx) * 2 / k.fx, (3 - k.cy) * 2 / k.fy, 2.0]])
    uv, front = project(k.K, [[0.0, 0.0, -1.0]])
    assert not front[0] and np.isnan(uv).all()


def test_mount_is_flu_to_rdf_with_pitch_down() -> None:
    T = CameraConfig(mount_height_m=0.5, mount_forward_m=0.1, mount_pitch_deg=0.0).T_body_cam()
    np.testing.assert_allclose(T[:3, 2], [1, 0, 0], atol=1e-12)  # optical axis = body forward
    np.testing.assert_allclose(T[:3, 0], [0, -1, 0], atol=1e-12)  # image right = body right
    np.testing.assert_allclose(T[:3, 3], [0.1, 0, 0.5])
    down = CameraConfig(mount_pitch_deg=30.0).T_body_cam()
    assert down[2, 2] == pytest.approx(-0.5)  # optical axis tilted 30 deg down
    p = transform_points(T, [[0.0, 0.0, 2.0]])  # 2 m ahead of the camera
    np.testing.assert_allclose(p, [[2.1, 0.0, 0.5]], atol=1e-12)


@pytest.mark.parametrize(
    "data, field",
    [
        ({"width": 0}, "width"),
        ({"hfov_deg": 200}, "hfov_deg"),
        ({"max_depth_m": -1}, "max_depth_m"),
        ({"fov": 3}, "fov"),
    ],
)
def test_invalid_camera_config(data: dict, field: str) -> None:
    with pytest.raises(ConfigError, match=field):
        validate_model(CameraConfig, data)


@pytest.mark.parametrize(
    "intr, field",
    [
        (Intrinsics(64, 48, -1.0, 50.0, 31.5, 23.5), "fx"),
        (Intrinsics(64, 48, 50.0, float("nan"), 31.5, 23.5), "fy"),
        (Intrinsics(64, 48, 50.0, 50.0, 100.0, 23.5), "cx"),
        (Intrinsics(0, 48, 50.0, 50.0, 0.0, 23.5), "width"),
    ],
)
def test_invalid_intrinsics(intr: Intrinsics, field: str) -> None:
    with pytest.raises(ConfigError, match=field):
        check_intrinsics(intr)


def test_backproject_shape_mismatch() -> None:
    k = CameraConfig(width=16, height=12).intrinsics()
    with pytest.raises(ConfigError, match="shape"):
        backproject(np.ones((10, 10)), k)
