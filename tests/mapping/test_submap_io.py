"""Submap placement/membership/frames against hand-computed cases; storage round trips."""

from collections import Counter

import numpy as np
import pytest

from roman_sim.core.errors import StorageError
from roman_sim.core.geometry import make_T, pose_4dof, rpy_to_R, transform_points
from roman_sim.mapping.io import (
    load_segment_map,
    load_submaps,
    mb_per_km,
    packet_bytes,
    save_segment_map,
    save_submaps,
    submaps_mb_per_km,
)
from roman_sim.mapping.mapper import SegmentMap
from roman_sim.mapping.segment import Segment, Status
from roman_sim.mapping.submap import SubmapConfig, build_submaps, center_indices


def _seg(i, centre, t0, t1, oid=None, dim=8):
    pts = np.asarray(centre) + np.random.default_rng(i).uniform(-0.3, 0.3, (30, 3))
    d = np.random.default_rng(100 + i).standard_normal(dim)
    return Segment(i, pts, t0, t1, 3, d, Counter({oid if oid is not None else i: 25, -1: 5}), Status.FINISHED)


def _map():
    # robot drives along +x at 1 m/s for 30 s, odometry with a small roll and a yaw offset
    times = np.arange(0, 31.0)
    T_w = np.stack([pose_4dof(t, 0, 0, 0) for t in times])
    T_o = np.stack([make_T(rpy_to_R(0.02, -0.01, 0.3), [t, 1.0, 0]) for t in times])
    segs = [
        _seg(0, [2, 3, 0], 0, 3),
        _seg(1, [12, -2, 1], 5, 14),
        _seg(2, [40, 0, 0], 28, 30),
        _seg(3, [21, 0, 0], 19, 22),
        _seg(4, [5, 0, 0], 90, 95),
    ]
    return SegmentMap("r", segs, times, T_o, T_w)


def test_center_indices_by_distance_and_time():
    times = np.arange(0, 200.0, 1.0)
    T = np.stack([pose_4dof(0.1 * t if t < 100 else 10 + 0.0 * t, 0, 0, 0) for t in times])
    idx = center_indices(times, T, SubmapConfig())
    # distance: 10 m reached only after t=100 (0.1 m/s); time: > 50 s
    assert idx == [0, 51, 102, 153]
    assert center_indices(np.zeros(0), np.zeros((0, 4, 4)), SubmapConfig()) == []


def test_submap_membership_and_frames():
    smap = _map()
    subs = build_submaps(smap, SubmapConfig(submap_radius=15.0, time_window_s=50.0))
    assert [s.t for s in subs] == [0.0, 11.0, 22.0]
    s1 = subs[1]
    # centre at odom (11, 1, 0); segment 2 at 40 is out of radius, 4 is out of time window
    assert s1.segment_ids.tolist() == [1, 0, 3]  # distances 3.3, 9.2, 10.0
    T_os = s1.T_odom_submap
    np.testing.assert_allclose(T_os, make_T(rpy_to_R(0, 0, 0.3), [11, 1, 0]), atol=1e-12)
    np.testing.assert_allclose(transform_points(T_os, s1.centers[0:1])[0], smap.segments[1].center, atol=1e-12)
    np.testing.assert_allclose(s1.truth.T_world_submap, pose_4dof(11, 0, 0, 0))
    assert s1.truth.object_ids.tolist() == [1, 0, 3]
    np.testing.assert_allclose(s1.truth.purity, 25 / 30)
    assert s1.public().truth is None and s1.descriptors.shape == (3, 8)


def test_submap_max_size_keeps_closest():
    subs = build_submaps(_map(), SubmapConfig(submap_max_size=2))
    assert subs[1].segment_ids.tolist() == [1, 0]


def test_segment_map_round_trip_is_exact(tmp_path):
    smap = _map()
    smap.segments[2].descriptor_sum = None
    save_segment_map(tmp_path / "m.npz", smap)
    back = load_segment_map(tmp_path / "m.npz")
    assert back.robot == "r" and len(back) == len(smap)
    np.testing.assert_array_equal(back.T_odom_body, smap.T_odom_body)
    for a, b in zip(smap.segments, back.segments):
        assert (a.id, a.first_seen, a.last_seen, a.num_sightings, a.status, a.truth_counts) == (
            b.id,
            b.first_seen,
            b.last_seen,
            b.num_sightings,
            b.status,
            b.truth_counts,
        )
        np.testing.assert_array_equal(a.points, b.points)
        assert (a.descriptor is None) == (b.descriptor is None)
        if a.descriptor is not None:
            np.testing.assert_array_equal(a.descriptor, b.descriptor)


def test_submaps_round_trip_is_exact(tmp_path):
    subs = build_submaps(_map(), SubmapConfig(keep_points=True, descriptor_dtype="float16"))
    subs[0] = subs[0].public()
    save_submaps(tmp_path / "s.npz", subs)
    back = load_submaps(tmp_path / "s.npz")
    assert len(back) == len(subs) and back[0].truth is None
    for a, b in zip(subs, back):
        assert (a.robot, a.index, a.t) == (b.robot, b.index, b.t)
        for f in ("T_odom_submap", "segment_ids", "centers", "volumes", "shape", "descriptors", "extents"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
            assert getattr(a, f).dtype == getattr(b, f).dtype
        assert all(np.array_equal(p, q) for p, q in zip(a.points, b.points))
    np.testing.assert_array_equal(back[1].truth.T_world_submap, subs[1].truth.T_world_submap)


def test_corrupt_wrong_version_and_wrong_format_files(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(StorageError, match="not a readable"):
        load_segment_map(bad)
    with pytest.raises(StorageError, match="not found"):
        load_submaps(tmp_path / "missing.npz")
    save_submaps(tmp_path / "s.npz", build_submaps(_map()))
    with pytest.raises(StorageError, match="expected format"):
        load_segment_map(tmp_path / "s.npz")
    import json

    from roman_sim.core.atomic import write_npz

    hdr = np.frombuffer(json.dumps({"format": "roman_sim.submaps", "version": 99, "submaps": []}).encode(), np.uint8)
    write_npz(tmp_path / "v.npz", header=hdr)
    with pytest.raises(StorageError, match="version 99"):
        load_submaps(tmp_path / "v.npz")


def test_packet_bytes_and_mb_per_km():
    rng = np.random.default_rng(0)
    segs = [_seg(i, rng.uniform(-10, 10, 3), 0, 1, dim=768) for i in range(40)]
    smap = SegmentMap("r", segs, np.array([0.0]), np.eye(4)[None], np.eye(4)[None])
    sub = build_submaps(smap, SubmapConfig(submap_radius=100))[0]
    assert len(sub) == 40
    n = packet_bytes(sub)
    assert 40 * 768 * 2 * 0.8 < n <= 125_000  # float16 descriptors dominate
    assert packet_bytes(sub.public()) == n
    assert mb_per_km(2_000_000, 500.0) == pytest.approx(4.0)
    assert submaps_mb_per_km([sub, sub], 1000.0) == pytest.approx(2 * n / 1e6)
    assert np.isnan(mb_per_km(10, 0.0))
