"""Keyframes in submap files (format version 2, version 1 still read) and in the packet size."""

from __future__ import annotations

import json
import zipfile
from dataclasses import replace

import numpy as np
import pytest

from roman_sim.align.visual.bow import BowVector
from roman_sim.align.visual.features import KeyframeFeatures
from roman_sim.align.visual.keyframes import Keyframe, keyframe_set
from roman_sim.core.errors import StorageError
from roman_sim.core.geometry import pose_4dof
from roman_sim.mapping.io import (
    FORMAT_VERSION,
    keyframe_packet_bytes,
    load_submaps,
    packet_bytes,
    save_submaps,
    submaps_mb_per_km,
)
from roman_sim.mapping.submap import SubmapConfig, make_submap


def _keyframes(seed: int, n: int = 3, feats: int = 200) -> list[Keyframe]:
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        f = KeyframeFeatures(
            rng.uniform(0, 640, (feats, 2)).astype(np.float32),
            rng.integers(0, 256, (feats, 32), dtype=np.uint8),
            rng.uniform(0.5, 7.5, (feats, 3)).astype(np.float32),
        )
        words = np.unique(rng.integers(0, 9000, 150)).astype(np.int32)
        v = rng.random(len(words)).astype(np.float32)
        out.append(
            Keyframe(
                float(i),
                pose_4dof(i, 0, 0.4, 0.1 * i),
                np.array([300.0, 400.0, 319.5, 239.5]),
                f,
                BowVector(words, v / v.sum()),
            )
        )
    return out


def _submap(with_kf: bool, n_kf: int = 3):
    s = make_submap("r", 0, 1.0, pose_4dof(1, 0, 0, 0.2), pose_4dof(1, 0.5, 0, 0.25), [], SubmapConfig())
    return replace(s, keyframes=keyframe_set(_keyframes(0, n_kf), s.T_odom_submap)) if with_kf else s


def test_round_trip_keeps_every_keyframe_array_exactly(tmp_path) -> None:
    subs = [_submap(True), _submap(False)]
    save_submaps(tmp_path / "s.npz", subs)
    back = load_submaps(tmp_path / "s.npz")
    assert back[1].keyframes is None
    k0, k1 = subs[0].keyframes, back[0].keyframes
    for f in k0.FIELDS:
        a, b = getattr(k0, f), getattr(k1, f)
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    assert back[0].public().keyframes is not None  # robot data, not truth
    words, values = k1.bow(2)
    np.testing.assert_array_equal(words, _keyframes(0)[2].bow.words)
    assert values.sum() == pytest.approx(1.0, abs=1e-6)


def test_version_1_files_are_still_read(tmp_path) -> None:
    save_submaps(tmp_path / "s.npz", [_submap(False)])
    with np.load(tmp_path / "s.npz") as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(arrays.pop("header").tobytes())
    assert header["version"] == FORMAT_VERSION == 2
    header["version"] = 1
    for m in header["submaps"]:
        m.pop("keyframes")
    np.savez(tmp_path / "v1.npz", header=np.frombuffer(json.dumps(header).encode(), np.uint8), **arrays)
    (old,) = load_submaps(tmp_path / "v1.npz")
    assert old.keyframes is None and old.truth is not None
    header["version"] = 3
    np.savez(tmp_path / "v3.npz", header=np.frombuffer(json.dumps(header).encode(), np.uint8), **arrays)
    with pytest.raises(StorageError, match="version 3 not supported"):
        load_submaps(tmp_path / "v3.npz")
    assert zipfile.is_zipfile(tmp_path / "v1.npz")


def test_keyframe_packet_is_counted_apart_from_the_segment_packet() -> None:
    bare, with_kf, more = _submap(False), _submap(True, 3), _submap(True, 6)
    seg = packet_bytes(bare)
    assert packet_bytes(with_kf) == seg  # ROMAN's packet is unchanged by keyframes
    assert keyframe_packet_bytes(bare) == 0 == packet_bytes(bare, "keyframes")
    kf3, kf6 = packet_bytes(with_kf, "keyframes"), packet_bytes(more, "keyframes")
    # 600 features of 32 descriptor bytes (random: incompressible) at least
    assert kf3 > 600 * 32 and kf6 > 1.9 * (kf3 - 1000)
    assert packet_bytes(with_kf, "all") == seg + kf3
    assert submaps_mb_per_km([with_kf], 100.0, "keyframes") == pytest.approx(kf3 / 1e6 / 0.1)
    with pytest.raises(StorageError, match="packet part"):
        packet_bytes(bare, "everything")  # type: ignore[arg-type]


def test_keyframe_file_round_trip_and_split_between_submaps(tmp_path) -> None:
    from roman_sim.align.visual.keyframes import attach_keyframes
    from roman_sim.mapping.io import load_keyframes, save_keyframes

    kfs = _keyframes(1, n=5, feats=20)  # times 0..4, odometry poses x = 0..4
    odom = keyframe_set(kfs, np.eye(4))
    save_keyframes(tmp_path / "k.npz", odom)
    back = load_keyframes(tmp_path / "k.npz")
    for f in odom.FIELDS:
        np.testing.assert_array_equal(getattr(odom, f), getattr(back, f))
    with pytest.raises(StorageError, match="expected format"):
        load_submaps(tmp_path / "k.npz")
    subs = [
        make_submap("r", i, t, pose_4dof(x, 1.0, 0, 0.3), None, [], SubmapConfig())
        for i, (t, x) in enumerate([(0.0, 0.0), (3.0, 3.0)])
    ]
    parts = attach_keyframes(subs, back)
    np.testing.assert_array_equal(parts[0].keyframes.t, [0.0, 1.0])  # t = 2 is nearer the centre at 3 s
    np.testing.assert_array_equal(parts[1].keyframes.t, [2.0, 3.0, 4.0])
    k = parts[1].keyframes
    np.testing.assert_allclose(subs[1].T_odom_submap @ k.T_submap_cam[0], kfs[2].T_odom_cam, atol=1e-12)
    _, desc, pts = k.features(1)
    np.testing.assert_array_equal(desc, kfs[3].features.descriptors)
    np.testing.assert_array_equal(pts, kfs[3].features.points)
    np.testing.assert_array_equal(k.bow(2)[0], kfs[4].bow.words)
    assert sum(len(p.keyframes) for p in parts) == 5
    assert attach_keyframes([], back) == []
