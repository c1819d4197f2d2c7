"""MuJoCo rendering: exact depth of known geometry, ids against truth, cross-check with pyrender."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import SimError
from roman_sim.core.geometry import R_FLU_RDF, inv_T, make_T, rot_x, rot_y, rot_z, transform_points
from roman_sim.core.sensors import backproject
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.kinematics import PlanarState, body_pose_on_terrain
from roman_sim.sim.render import SensorRenderer

from .conftest import BOX_CENTER, BOX_HALF

CAM = CameraConfig(width=160, height=120)


@pytest.fixture(scope="module")
def box_renderer(plane_box_world):
    r = SensorRenderer(plane_box_world, CAM, rgb=True)
    yield r
    r.close()


def test_level_camera_sees_box_face_and_ground_exactly(box_renderer) -> None:
    k = CAM.intrinsics()
    rgb, depth, ids = box_renderer.render(make_T(R_FLU_RDF, [0.0, 0.0, 0.5]))
    assert rgb is not None and rgb.shape == (120, 160, 3) and rgb.dtype == np.uint8
    assert depth.dtype == np.float32 and ids.dtype == np.int32
    # Box front face x = 4.5 straight ahead; ground rows below the box: z = h * fy / (v - cy).
    assert depth[60, 80] == pytest.approx(4.5, abs=1e-4) and ids[60, 80] == 0
    for v in (80, 100, 119):
        assert depth[v, 5] == pytest.approx(0.5 * k.fy / (v - k.cy), rel=1e-4)
        assert ids[v, 5] == -1
    assert depth[0, 0] == 0.0 and ids[0, 0] == -1  # sky


def test_looking_down_with_yaw_and_roll_sees_flat_ground(box_renderer) -> None:
    # Optical axis straight down (RDF z = world -z) from 3 m, rotated about it by 0.7 rad.
    R = rot_z(0.7) @ rot_x(np.pi)
    _, depth, ids = box_renderer.render(make_T(R, [-3.0, -2.0, 3.0]))
    assert np.all(ids == -1)
    np.testing.assert_allclose(depth, 3.0, atol=2e-4)


def test_box_pixels_backproject_inside_box(box_renderer) -> None:
    T_wc = make_T(rot_z(0.4) @ rot_y(0.25) @ R_FLU_RDF, [1.0, -1.5, 1.6])
    _, depth, ids = box_renderer.render(T_wc)
    pts = transform_points(T_wc, backproject(depth, CAM.intrinsics(), ids == 0))
    assert len(pts) > 100
    assert np.all(np.abs(pts - BOX_CENTER) <= BOX_HALF + 1e-3)
    # and the box faces are hit: some point lies on each visible face plane
    assert np.max(np.abs(pts - BOX_CENTER).max(axis=1) - 0.5) < 1e-3


def test_bad_pose_and_closed_renderer(plane_box_world) -> None:
    r = SensorRenderer(plane_box_world, CAM, rgb=False)
    assert r.render(make_T(R_FLU_RDF, [0, 0, 0.5]))[0] is None
    with pytest.raises(SimError, match="T_world_cam"):
        r.render(np.eye(3))
    r.close()
    r.close()
    with pytest.raises(SimError, match="closed"):
        r.render(np.eye(4))


def test_too_large_image_is_an_error(plane_box_world) -> None:
    with pytest.raises(SimError, match="offscreen buffer"):
        SensorRenderer(plane_box_world, CameraConfig(width=640, height=480))


def _view_of(world, obj_index: int, dist: float = 4.0) -> np.ndarray:
    c = world.truth.objects[obj_index].T_world_obj[:2, 3]
    st = PlanarState(float(c[0] - dist), float(c[1]), 0.0)
    return body_pose_on_terrain(world.truth.terrain, st, 0.1) @ CAM.T_body_cam()


def test_object_pixels_lie_in_their_oriented_boxes(tiny_world) -> None:
    r = SensorRenderer(tiny_world, CAM, rgb=False)
    try:
        seen = 0
        for i in range(0, len(tiny_world.truth.objects), 4):
            T_wc = _view_of(tiny_world, i)
            _, depth, ids = r.render(T_wc)
            for oid in np.unique(ids[ids >= 0]):
                obj = tiny_world.truth.objects[int(oid)]
                pts = transform_points(T_wc, backproject(depth, CAM.intrinsics(), ids == oid))
                local = transform_points(inv_T(obj.obb_T_world), pts)
                assert np.all(np.abs(local) <= obj.obb_extents / 2 + 0.01), f"object {oid}"
                seen += 1
        assert seen >= 5
    finally:
        r.close()


def test_same_pose_same_images(tiny_world) -> None:
    r = SensorRenderer(tiny_world, CAM, rgb=True)
    try:
        a = r.render(_view_of(tiny_world, 0))
        b = r.render(_view_of(tiny_world, 0))
    finally:
        r.close()
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def _both_depths(world, T_wc):
    """MuJoCo depth and ids, and pyrender depth over the world's meshes, from one camera pose."""
    from roman_sim.sim.pyrender_check import pyrender_depth, world_meshes

    r = SensorRenderer(world, CAM, rgb=False)
    try:
        _, d_mj, ids = r.render(T_wc)
    finally:
        r.close()
    return d_mj, ids, pyrender_depth(world_meshes(world), CAM.intrinsics(), T_wc, CAM.near_m, CAM.far_m)


def test_pyrender_agrees_with_mujoco(tiny_world) -> None:
    d_mj, _, d_pr = _both_depths(tiny_world, _view_of(tiny_world, 0, dist=5.0))
    valid = (d_mj > 0) & (d_pr > 0)
    assert valid.mean() > 0.3
    assert float(np.median(np.abs(d_mj - d_pr)[valid])) < 0.01
    assert ((d_mj > 0) != (d_pr > 0)).mean() < 0.02


def test_exported_world_renders_like_the_original_meshes(tiny_world, tmp_path) -> None:
    from roman_sim.world import export_world, load_world

    export_world(tiny_world, tmp_path / "w")
    loaded = load_world(tmp_path / "w")
    d_mj, ids, d_pr = _both_depths(loaded, _view_of(tiny_world, 1, dist=4.0))
    valid = (d_mj > 0) & (d_pr > 0)
    assert valid.mean() > 0.3 and (ids >= 0).any()
    assert float(np.median(np.abs(d_mj - d_pr)[valid])) < 0.01
