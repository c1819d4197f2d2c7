"""The ``visual`` aligner on submaps built from rendered keyframes, against the true submap poses."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from roman_sim.align import build_aligner
from roman_sim.align.visual import (
    KeyframeExtractor,
    KeyframeParams,
    attach_keyframes,
    default_vocabulary,
)
from roman_sim.align.visual.aligner import VisualParams, candidates, neighbour_scores
from roman_sim.align.visual.bow import BowVector
from roman_sim.align.visual.keyframes import keyframe_set
from roman_sim.core.errors import ConfigError, MappingError
from roman_sim.core.geometry import gravity_aligned, inv_T, pose_4dof, pose_error
from roman_sim.core.sensors import Frame
from roman_sim.mapping.submap import SubmapConfig, make_submap
from roman_sim.mapping.types import KeyframeSet

from .conftest import CAM


def _robot_submap(shooter, name: str, poses: list[tuple[float, float, float]], drift: np.ndarray):
    """One submap (no segments) of a robot driving ``poses``; odometry = ``drift`` @ truth (4 DoF)."""
    T_bc = CAM.T_body_cam()
    ex = KeyframeExtractor(default_vocabulary(), KeyframeParams(every_m=0.3))
    T_wb = []
    for i, p in enumerate(poses):
        T_wc, rgb, depth = shooter.frame(*p)
        T_wb.append(T_wc @ inv_T(T_bc))
        ex.offer(Frame(name, i, float(i), rgb, depth, drift @ T_wb[-1], T_bc, shooter.K))
    c = len(poses) // 2
    sub = make_submap(name, 0, float(c), drift @ T_wb[c], T_wb[c], [], SubmapConfig())
    return attach_keyframes([sub], ex.keyframe_set())[0]


@pytest.fixture(scope="module")
def submaps(shooter):
    line = [(x, 0.0, 0.0) for x in np.linspace(-1.0, 1.0, 7)]
    a = _robot_submap(shooter, "a", line, np.eye(4))
    b = _robot_submap(shooter, "b", [(x + 0.4, 0.3, 10.0) for x, _, _ in line], pose_4dof(5.0, -3.0, 0.2, 0.8))
    c = _robot_submap(shooter, "c", [(x, 0.0, 180.0) for x, _, _ in line], pose_4dof(-2.0, 1.0, 0.0, -0.3))
    return a, b, c


def _truth(a, b) -> np.ndarray:
    return inv_T(a.truth.T_world_submap) @ b.truth.T_world_submap


def test_same_place_aligns_to_the_true_submap_pose(submaps) -> None:
    a, b, _ = submaps
    assert len(a.keyframes) == 7 and len(b.keyframes) == 7  # 0.33 m steps, one keyframe each
    r = build_aligner("visual").align(a.public(), b.public())
    assert r.ok and r.n_associations >= 5 and r.info["normalised_score"] > 0.4
    # its own scores: the verified keyframe pair's bag-of-words score and feature matches
    assert r.named_scores() == {
        "associations": r.n_associations,
        "bow_score": r.info["normalised_score"],
        "matches": r.info["n_matches"],
    }
    # the reprojection refinement (on by default, for noisy depth) leaves up to about 1 deg on
    # these clean 320 x 240 frames (3D-3D alone: 0.3 deg), and the winning keyframes sit up to
    # 1 m from their submap centres
    for x, y in ((a, b), (b, a)):
        r = build_aligner("visual").align(x.public(), y.public())
        rot, trans = pose_error(r.T_a_b, _truth(x, y))
        assert r.ok and np.degrees(rot) < 2.0 and trans < 0.2
        r = build_aligner("visual", {"verify": {"refine_reprojection": False}}).align(x.public(), y.public())
        rot, trans = pose_error(r.T_a_b, _truth(x, y))
        assert r.ok and np.degrees(rot) < 0.5 and trans < 0.05


def test_opposite_heading_and_missing_keyframes_are_rejected(submaps) -> None:
    a, _, c = submaps
    r = build_aligner("visual").align(a.public(), c.public())
    assert not r.ok and r.n_associations < 5
    bare = replace(a, keyframes=None)
    r = build_aligner("visual").align(bare, c)
    assert not r.ok and "render_rgb" in r.reason and r.n_associations == 0


def test_alpha_above_every_normalised_score_gives_no_candidate(submaps) -> None:
    a, b, _ = submaps
    r = build_aligner("visual", {"alpha": 100.0}).align(a.public(), b.public())
    assert not r.ok and "alpha" in r.reason and r.info["best_normalised_score"] > 0.4
    with pytest.raises(ConfigError, match="alpha"):
        build_aligner("visual", {"alpha": -1.0})
    with pytest.raises(ConfigError, match="lowe_ratio"):
        build_aligner("visual", {"verify": {"lowe_ratio": 2.0}})


def _set(vectors: list[dict[int, float]]) -> KeyframeSet:
    from roman_sim.align.visual.features import KeyframeFeatures
    from roman_sim.align.visual.keyframes import Keyframe

    kfs = []
    for v in vectors:
        w = np.array(sorted(v), np.int32)
        vals = np.array([v[i] for i in w], np.float32)
        feats = KeyframeFeatures(
            np.zeros((0, 2), np.float32), np.zeros((0, 32), np.uint8), np.zeros((0, 3), np.float32)
        )
        kfs.append(Keyframe(0.0, np.eye(4), np.ones(4), feats, BowVector(w, vals / vals.sum())))
    return keyframe_set(kfs, np.eye(4))


def test_candidates_are_normalised_by_the_previous_keyframe_by_hand() -> None:
    # a0 and a1 share half their mass (s = 0.5); a2 shares 0.2 with a1
    a = _set([{0: 1, 1: 1}, {1: 1, 2: 1}, {2: 0.2, 3: 0.8}])
    b = _set([{3: 1}, {0: 1, 5: 1}])
    np.testing.assert_allclose(neighbour_scores([BowVector(*a.bow(i)) for i in range(3)]), [0.5, 0.5, 0.2], atol=1e-6)
    # raw scores: a2-b0 = 0.8 -> 0.8 / 0.2 = 4; a0-b1 = 0.5 -> 1.0; a1-b* = 0
    cands, best = candidates(a, b, VisualParams(max_candidates=3))
    assert [(q, c) for q, c, _ in cands] == [(2, 0), (0, 1)]
    np.testing.assert_allclose([s for *_, s in cands], [4.0, 1.0], rtol=1e-5)
    assert best == pytest.approx(4.0, rel=1e-5)
    assert candidates(a, b, VisualParams(alpha=4.5))[0] == []
    assert candidates(_set([{0: 1}]), b, VisualParams())[0] == []  # a lone keyframe has no neighbour


def test_extractor_needs_rgb_and_spaces_keyframes_by_odometry(shooter) -> None:
    ex = KeyframeExtractor(default_vocabulary(), KeyframeParams(every_m=1.0, every_s=100.0))
    _, rgb, depth = shooter.frame(0.0, 0.0, 0.0)
    with pytest.raises(MappingError, match="render_rgb"):
        ex.offer(Frame("r", 0, 0.0, None, depth, np.eye(4), np.eye(4), shooter.K))
    due = [
        ex.offer(Frame("r", i, float(i), rgb, depth, pose_4dof(0.4 * i, 0, 0, 0), np.eye(4), shooter.K)) is not None
        for i in range(6)
    ]
    assert due == [True, False, False, True, False, False]  # 0, 1.2 m; 2.0 m is 0.8 m past the last
    turned = ex.offer(Frame("r", 6, 6.0, rgb, depth, pose_4dof(1.2, 0, 0, np.radians(20)), np.eye(4), shooter.K))
    assert turned is not None and len(ex.keyframes) == 3
    sub = make_submap("r", 0, 0.0, pose_4dof(1.0, 0.0, 0.0, 0.5), None, [], SubmapConfig())
    kf = attach_keyframes([sub], ex.keyframes)[0].keyframes
    T_sub_cam = inv_T(gravity_aligned(pose_4dof(1.0, 0.0, 0.0, 0.5))) @ pose_4dof(1.2, 0, 0, 0)
    np.testing.assert_allclose(kf.T_submap_cam[1], T_sub_cam, atol=1e-12)
    assert kf.feat_offsets[-1] == len(kf.descriptors) == sum(len(k.features) for k in ex.keyframes)
