"""What the simulator tells a truth-driven model of a mask (each object's pixel share), and the
partial-views bundle split by reason: each surface sample's reasons agree with what the renderer drew,
and switching one reason off fills in only the samples missed for that reason alone."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial import cKDTree

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import transform_points
from roman_sim.core.sensors import Frame
from roman_sim.frontend.segmenter import SegmenterConfig, SimulatedSegmenter
from roman_sim.frontend.surface_completion import REASONS, SurfaceCompletion, classify
from roman_sim.mapping.tracker import MappingConfig
from roman_sim.sim.camera import CameraConfig
from roman_sim.world import World
from tests.studies.test_heading_mechanisms import H, W, _facing, _frame, _long_axis_bearing, _obs_of, _world

VOXEL = MappingConfig().voxel


@pytest.fixture(scope="module")
def car() -> World:
    w = _world([{"name": "car", "density": 20}])
    assert [o.family for o in w.truth.objects] == ["car"]
    return w


def _side_on(world: World, dist_m: float, flip: int = 0) -> Frame:
    side = _long_axis_bearing(world, 0) + math.pi / 2 + flip * math.pi
    return _frame(world, CameraConfig(width=W, height=H), _facing(world, 0, side, dist_m), flip)


def _reasons(comp: SurfaceCompletion, frame: Frame) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    pts, nrm = comp.samples(0)
    T_cam_world = np.linalg.inv(frame.truth.T_world_body @ frame.T_body_cam)  # type: ignore[union-attr]
    pc = transform_points(T_cam_world, pts)
    return pc, classify(frame, 0, pc, nrm @ T_cam_world[:3, :3].T, comp.max_depth_m, comp.tol)


def test_the_reasons_agree_with_what_the_renderer_drew(car: World) -> None:
    """Side-on at 4 m: every point the depth image gives lies on a sample with no reason (seen), and the
    samples turned away lie far from every observed point (the car's far side, 1.5 m behind)."""
    f = _side_on(car, 4.0)
    comp = SurfaceCompletion(car, VOXEL, 7.5, [])
    pc, why = _reasons(comp, f)
    seen = ~np.any(np.stack(list(why.values())), axis=0)
    assert not why["out_of_view"].any() and not why["beyond_range"].any()
    assert why["occluded"].mean() < 0.05  # the wheels' lowest faces, below the ground's surface
    assert why["back_side"].mean() > 0.5 and seen.sum() > 100  # from one side most of a car is out of sight
    T_cam_odom = np.linalg.inv(f.T_odom_cam)
    observed = transform_points(T_cam_odom, _obs_of(f, 0).points)
    d_seen, _ = cKDTree(pc[seen]).query(observed)
    assert np.median(d_seen) < 0.05, np.median(d_seen)
    d_back, _ = cKDTree(observed).query(pc[why["back_side"]])
    assert np.median(d_back) > 0.5, np.median(d_back)


def test_one_sided_visibility_off_brings_opposite_views_together(car: World) -> None:
    """The car side-on from opposite sides: the observed centroids lie most of its width apart; with the
    back side filled in they lie within a fifth of it."""
    width = float(min(car.truth.objects[0].obb_extents[:2]))
    frames = [_side_on(car, 4.0, k) for k in (0, 1)]
    plain = [_obs_of(f, 0).points.mean(axis=0) for f in frames]
    comp = SurfaceCompletion(car, VOXEL, 7.5, ["back_side"])
    filled = [_obs_of(f, 0, comp).points.mean(axis=0) for f in frames]
    assert np.linalg.norm((plain[0] - plain[1])[:2]) > 0.4 * width
    assert np.linalg.norm((filled[0] - filled[1])[:2]) < 0.2 * width


def _added(car: World, f: Frame, off: list[str], max_depth_m: float = 7.5) -> np.ndarray:
    return SurfaceCompletion(car, VOXEL, max_depth_m, off).missed(f, 0)


def test_each_reason_switched_off_alone_fills_in_only_its_own_samples(car: World) -> None:
    """Three views each make one more reason appear (an occluding band drawn into the depth image, a
    short range, a close camera); a reason switched off alone adds exactly the samples missed for it
    alone, and every reason switched off adds every sample with any reason."""
    base = _side_on(car, 4.0)
    depth = np.array(base.depth)
    depth[:, W // 2 - 8 : W // 2 + 8] = 1.0  # a pole 1 m in front of the camera
    views = {"occluded": (replace(base, depth=depth), 7.5), "beyond_range": (base, 4.1)}
    views["out_of_view"] = (_side_on(car, 1.6), 7.5)
    views["back_side"] = (base, 7.5)
    for reason, (f, rng) in views.items():
        comp = SurfaceCompletion(car, VOXEL, rng, [])
        pc, why = _reasons(comp, f)
        only = why[reason] & ~np.any(np.stack([why[r] for r in REASONS if r != reason]), axis=0)
        assert only.sum() > 20, (reason, only.sum())
        np.testing.assert_array_equal(_added(car, f, [reason], rng), only)
        np.testing.assert_array_equal(_added(car, f, list(REASONS), rng), np.any(np.stack(list(why.values())), axis=0))
    comp = SurfaceCompletion(car, VOXEL, 7.5, [])
    pc, before = _reasons(comp, base)
    new = _reasons(comp, views["occluded"][0])[1]["occluded"] & ~before["occluded"]
    u = f.intrinsics.fx * pc[new, 0] / pc[new, 2] + f.intrinsics.cx
    assert new.sum() > 20 and np.all((u >= W // 2 - 8) & (u < W // 2 + 8))  # what the band adds lies behind it
    far = _reasons(SurfaceCompletion(car, VOXEL, 4.1, []), base)[1]["beyond_range"]
    assert np.all(pc[far, 2] > 4.1)


def test_the_switch_is_checked_and_needs_the_world(car: World) -> None:
    from roman_sim.mapping.mapper import Mapper

    with pytest.raises(ConfigError, match="complete: whole_surface already fills in every reason"):
        validate_model(MappingConfig, {"whole_surface": True, "complete": ["back_side"]}, "mapping")
    with pytest.raises(ConfigError, match="complete"):
        validate_model(MappingConfig, {"complete": ["shadows"]}, "mapping")
    with pytest.raises(ConfigError, match="complete: each reason once"):
        validate_model(MappingConfig, {"complete": ["occluded", "occluded"]}, "mapping")
    with pytest.raises(ConfigError, match=r"^mapping.complete: .*allowed here: \[\]"):
        Mapper(MappingConfig(complete=["back_side"]), SimulatedSegmenter(SegmenterConfig(), 0))
    with pytest.raises(ConfigError, match="^mapping.complete: frame 0 of robot a has no ground truth"):
        SurfaceCompletion(car, VOXEL, 7.5, ["back_side"])(_side_on(car, 4.0).public(), [])
    with pytest.raises(ConfigError, match="unknown reason 'shadows'"):
        SurfaceCompletion(car, VOXEL, 7.5, ["shadows"])


def test_a_run_fills_in_the_back_sides_of_what_its_robots_map(tmp_path) -> None:
    """Through the maps stage: the same short smoke drives with ``mapping.complete=["back_side"]`` map the same
    objects, each segment with at least as many points, and more in all (the far sides added)."""
    from roman_sim.mapping.io import load_segment_map
    from roman_sim.testing import run_scenario

    short = ["robots.0.max_length_m=12", "robots.1.max_length_m=12"]
    runs = {
        name: run_scenario("smoke", overrides=[*short, *extra], out=tmp_path / name)
        for name, extra in (("plain", []), ("filled", ['mapping.complete=["back_side"]']))
    }
    maps = {k: load_segment_map(r.run_dir / "maps" / "a.npz") for k, r in runs.items()}
    ids = {k: sorted(s.majority_id for s in m.segments) for k, m in maps.items()}
    points = {k: sum(len(s.points) for s in m.segments) for k, m in maps.items()}
    assert ids["plain"] and len(ids["filled"]) >= len(ids["plain"]) - 1
    assert points["filled"] > 1.2 * points["plain"], points


def test_a_truth_reading_encoder_gets_each_objects_pixel_share(car: World) -> None:
    """A mask over the car and a band of ground below it: the context's shares are the pixel counts of the
    instance image under the mask's kept (valid-depth) pixels, over their total."""
    from roman_sim.mapping.mask import Mask
    from roman_sim.mapping.observation import observe

    f = _side_on(car, 4.0)
    ids = np.asarray(f.truth.object_ids)  # type: ignore[union-attr]
    rows = np.flatnonzero((ids == 0).any(axis=1))
    pixels = ids == 0
    pixels[rows.max() + 1 : rows.max() + 6, :] = True  # five rows of ground under the car
    got: list[tuple[tuple[int, float], ...] | None] = []

    class Recorder:
        reads_truth = True

        def encode(self, rgb, mask, context):  # type: ignore[no-untyped-def]
            got.append(context.shares)
            return np.ones(8, dtype=np.float32) / np.sqrt(8)

    obs = observe(f, [Mask(pixels)], MappingConfig(), Recorder())
    assert len(obs) == 1 and len(got) == 1 and got[0] is not None
    sel = pixels & (np.asarray(f.depth) > 0) & (np.asarray(f.depth) <= MappingConfig().max_depth_m)
    labels, counts = np.unique(ids[sel], return_counts=True)
    assert [i for i, _ in got[0]] == labels.tolist() == [-1, 0]
    assert [w for _, w in got[0]] == pytest.approx((counts / counts.sum()).tolist(), abs=1e-12)
