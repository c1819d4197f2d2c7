"""The renderer's fast paths against their reference paths on demo frames: the same bits.

Fast paths: frustum culling of mesh geoms (both passes), the id-colour decode through an RGBA
view, the depth linearisation in place, and the depth noise with OpenCV's 3x3 extremes.
"""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.pipeline.scenario import load_scenario
from roman_sim.sim.camera import CameraConfig, DepthNoiseConfig
from roman_sim.sim.noise import _extreme3, _filter3, apply_depth_noise
from roman_sim.sim.render import SensorRenderer
from roman_sim.sim.robot import plan_paths, trajectory_along
from roman_sim.world import generate


@pytest.fixture(scope="module")
def demo_poses():
    """The demo world and 60 camera poses of robot a spread along its loop (160 x 120)."""
    sc = load_scenario("demo")
    world = generate(sc.world.spec(), sc.seed)
    cfg = sc.robots[0].model_copy(update={"camera": CameraConfig(width=160, height=120)})
    _, T_wb, _ = trajectory_along(world, cfg, sc.seed, plan_paths(world, sc.simulated_robots(), sc.seed)["a"])
    T_bc = cfg.camera.T_body_cam()
    return world, cfg, [T_wb[i] @ T_bc for i in np.linspace(0, len(T_wb) - 1, 60).astype(int)]


def _decode_reference(r: SensorRenderer) -> tuple[np.ndarray, np.ndarray]:
    """Ids and depth of the last segmentation pass, decoded as the plain expressions do."""
    buf = r._rgb_buf[::-1]
    seg = buf[..., 0].astype(np.uint32)
    seg |= buf[..., 1].astype(np.uint32) << 8
    seg |= buf[..., 2].astype(np.uint32) << 16
    np.minimum(seg, len(r._seg_lut) - 1, out=seg)
    zbuf = r._depth_buf[::-1]
    n, f = np.float32(r._near), np.float32(r._far)
    c = -(f + n) / (f - n)
    d = -(np.float32(2) * f * n) / (f - n)
    c, d = np.float32(-0.5) * c - np.float32(0.5), np.float32(-0.5) * d
    with np.errstate(divide="ignore"):
        depth = d / (zbuf + c)
    depth[(zbuf <= 0) | (depth >= f * np.float32(0.999))] = 0.0
    return r._seg_lut[seg], depth.astype(np.float32, copy=False)


def test_culled_rendering_and_fast_decode_give_the_same_images(demo_poses) -> None:
    world, cfg, poses = demo_poses
    with SensorRenderer(world, cfg.camera) as fast, SensorRenderer(world, cfg.camera, cull=False) as full:
        assert fast._cull._rgb_ok and fast._cull._cullable.sum() > 100
        drawn = []
        for k, T in enumerate(poses):
            a, b = fast.render(T, rgb=k % 3 == 0), full.render(T, rgb=k % 3 == 0)
            drawn.append(int(fast._cull._shown.sum()))
            for x, y in zip(a, b):
                assert (x is None and y is None) or np.array_equal(x, y)
            _, depth, ids = fast.render(T, rgb=False)
            ref_ids, ref_depth = _decode_reference(fast)
            np.testing.assert_array_equal(ids, ref_ids)
            np.testing.assert_array_equal(depth, ref_depth)
            assert ids.flags.c_contiguous and depth.flags.c_contiguous
        assert np.mean(drawn) < 0.6 * fast._scene.ngeom  # most meshes lie outside the view


def _noise_reference(depth, cfg, max_depth_m, rng):
    """``apply_depth_noise`` as plain expressions with the numpy 3x3 filters."""
    d = np.asarray(depth, dtype=np.float32)
    valid = (d > 0) & (d <= max_depth_m)
    out = d.copy()
    std = np.float32(cfg.std_at_ref_m / cfg.ref_range_m**2) * d * d
    out += rng.standard_normal(d.shape, dtype=np.float32) * std
    q = np.float32(cfg.quantum_m)
    out = np.round(out / q) * q
    hi = _filter3(d, np.maximum)
    lo = _filter3(np.where(d > 0, d, np.float32(-1e6)), np.minimum)
    valid &= ~((d > 0) & ((hi - lo) > cfg.edge_jump_m))
    valid &= (out > 0) & (out <= max_depth_m)
    out[~valid] = 0.0
    return out


def test_depth_noise_matches_the_plain_expressions(demo_poses) -> None:
    world, cfg, poses = demo_poses
    with SensorRenderer(world, cfg.camera, rgb=False) as r:
        depths = [r.render(T)[1] for T in poses[:20]]
    for k, d in enumerate(depths):
        for noise in (DepthNoiseConfig(), DepthNoiseConfig(quantum_m=0.01, edge_jump_m=0.1)):
            a = apply_depth_noise(d, noise, 7.5, np.random.default_rng(k))
            b = _noise_reference(d, noise, 7.5, np.random.default_rng(k))
            np.testing.assert_array_equal(a, b)


def test_opencv_extremes_are_the_numpy_filters() -> None:
    rng = np.random.default_rng(3)
    for shape in ((1, 1), (1, 7), (5, 1), (13, 17), (120, 160)):
        img = rng.uniform(-2, 9, shape).astype(np.float32)
        img[rng.random(shape) < 0.1] = 0.0
        img[rng.random(shape) < 0.02] = np.inf
        for op in (np.maximum, np.minimum):
            np.testing.assert_array_equal(_extreme3(img, op), _filter3(img, op))
    img[3, 4] = np.nan  # OpenCV ignores NaN: the numpy filter runs
    for op in (np.maximum, np.minimum):
        np.testing.assert_array_equal(_extreme3(img, op), _filter3(img, op))
