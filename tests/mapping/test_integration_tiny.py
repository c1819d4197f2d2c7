"""Mapping on frames rendered in the tiny world (160 x 120, short path)."""

import dataclasses

import numpy as np
import pytest

from roman_sim.core.geometry import inv_T, pose_4dof, transform_points
from roman_sim.core.sensors import backproject
from roman_sim.frontend.segmenter import simulated_segmenter
from roman_sim.frontend.semantics import SimulatedEncoder
from roman_sim.mapping.io import load_segment_map, packet_bytes, save_segment_map
from roman_sim.mapping.mapper import Mapper
from roman_sim.mapping.submap import SubmapConfig, build_submaps
from roman_sim.mapping.tracker import MappingConfig
from roman_sim.mapping.voxels import downsample
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.robot import RobotConfig
from roman_sim.sim.source import robot_sources
from roman_sim.world import generate, load_world_spec


@pytest.fixture(scope="module")
def run():
    world = generate(load_world_spec("tiny"), 0)
    cfg = RobotConfig(
        name="a", camera=CameraConfig(width=160, height=120), drift="zero", render_rgb=False, max_duration_s=20.0
    )
    return world, list(robot_sources(world, [cfg], 0)[0].frames())


def _map(frames, segmenter="perfect", encoder=None):
    m = Mapper(MappingConfig(), simulated_segmenter(segmenter, 0), encoder)
    for f in frames:
        m.process(f)
    return m.finish()


def _visible(frames, max_depth=7.5):
    """Per object: world-frame centre of its visible voxels and the number of frames it filled."""
    pts: dict[int, list] = {}
    for f in frames:
        ok = (f.depth > 0) & (f.depth <= max_depth)
        for oid in np.unique(f.truth.object_ids[ok & (f.truth.object_ids >= 0)]):
            sel = ok & (f.truth.object_ids == oid)
            world_pts = transform_points(f.truth.T_world_body @ f.T_body_cam, backproject(f.depth, f.intrinsics, sel))
            pts.setdefault(int(oid), []).append(world_pts)
    return {k: downsample(np.vstack(v), 0.05).mean(axis=0) for k, v in pts.items()}


def _sufficiently_visible(frames, min_frames=5):
    """Objects with a perfect mask mostly within range in at least ``min_frames`` frames."""
    seg = simulated_segmenter("perfect")
    counts: dict[int, int] = {}
    for f in frames:
        for m in seg.segment(f):
            d = f.depth[m.pixels]
            if np.mean((d > 0) & (d <= 7.5)) >= 0.5:
                counts[m.object_ids[0]] = counts.get(m.object_ids[0], 0) + 1
    return {k for k, c in counts.items() if c >= min_frames}


def test_perfect_zero_drift_one_segment_per_visible_object(run):
    world, frames = run
    smap = _map(frames)
    T_wo = frames[0].truth.T_world_body @ inv_T(frames[0].T_odom_body)
    ids = [s.majority_id for s in smap.segments]
    assert len(ids) >= 3
    assert len(ids) == len(set(ids)), "duplicate segments of one object"
    assert _sufficiently_visible(frames) <= set(ids)
    visible = _visible(frames)
    for s in smap.segments:
        assert s.majority_id >= 0 and s.purity > 0.9
        centre_w = transform_points(T_wo, s.center[None])[0]
        assert np.linalg.norm(centre_w - visible[s.majority_id]) < 0.3


def test_constant_drift_moves_segments_by_the_drift(run):
    _, frames = run
    T_drift = pose_4dof(1.5, -0.8, 0.2, 0.1)
    drifted = [dataclasses.replace(f, T_odom_body=T_drift @ f.T_odom_body) for f in frames]
    plain = {s.majority_id: s.center for s in _map(frames).segments}
    moved = {s.majority_id: s.center for s in _map(drifted).segments}
    assert plain.keys() == moved.keys()
    for k in plain:
        np.testing.assert_allclose(moved[k], transform_points(T_drift, plain[k][None])[0], atol=0.05)


def test_fastsam_map_submaps_and_storage(run, tmp_path):
    world, frames = run
    enc = SimulatedEncoder(seed=0, families={o.id: o.family for o in world.truth.objects})
    smap = _map(frames, "fastsam", enc)
    assert len(smap) >= 2
    subs = build_submaps(smap, SubmapConfig(submap_center_dist=5.0))
    assert len(subs) >= 2 and all(len(s) <= 40 for s in subs)
    for s in subs:
        assert s.public().truth is None and packet_bytes(s) < 125_000
        np.testing.assert_allclose(s.T_odom_submap[2, :2], 0.0, atol=1e-12)  # gravity-aligned
    save_segment_map(tmp_path / "m.npz", smap)
    back = load_segment_map(tmp_path / "m.npz")
    assert [s.id for s in back.segments] == [s.id for s in smap.segments]


def test_typical_drift_segments_follow_the_drifted_odometry(run):
    world, frames = run
    cfg = RobotConfig(
        name="a", camera=CameraConfig(width=160, height=120), drift="typical", render_rgb=False, max_duration_s=20.0
    )
    t, T_wb, T_ob = robot_sources(world, [cfg], 0)[0].run
    np.testing.assert_allclose(T_wb, np.stack([f.truth.T_world_body for f in frames]), atol=1e-9)
    drifted = [dataclasses.replace(f, T_odom_body=T_ob[i]) for i, f in enumerate(frames)]
    smap = _map(drifted)
    visible = _visible(frames)
    assert len(smap) >= 3
    for s in smap.segments:
        idx = [i for i, ti in enumerate(t) if s.first_seen <= ti <= s.last_seen]
        expect = np.array([transform_points(T_ob[i] @ inv_T(T_wb[i]), visible[s.majority_id][None])[0] for i in idx])
        spread = np.max(np.linalg.norm(expect - expect.mean(axis=0), axis=1))
        assert np.linalg.norm(s.center - expect.mean(axis=0)) < 0.3 + spread
    # the drift is real: the odometry frame moves by more than 0.1 m against the world
    T_ow_end = T_ob[-1] @ inv_T(T_wb[-1])
    assert np.linalg.norm(T_ow_end[:3, 3] - (T_ob[0] @ inv_T(T_wb[0]))[:3, 3]) > 0.1
