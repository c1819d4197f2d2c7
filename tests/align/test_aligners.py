"""Aligners on synthetic pairs with known 4-DoF transforms, outliers and repeated layouts."""

from __future__ import annotations

from dataclasses import replace
from importlib.util import find_spec

import numpy as np
import pytest

from roman_sim.align import ALIGNERS, AlignResult, build_aligner
from roman_sim.align.affinity import build_affinity
from roman_sim.align.aligners import GravityParams
from roman_sim.align.clipper import _prepare
from roman_sim.align.clipper_rounding import clique_density
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import inv_T, pose_4dof, pose_error

FAST = {"ransac1m": {"iterations": 300_000}}


def _correct(r: AlignResult, T: np.ndarray, deg: float = 5.0, m: float = 1.0) -> bool:
    if not r.ok:
        return False
    rot, trans = pose_error(r.T_a_b, T)
    return bool(np.rad2deg(rot) <= deg and trans <= m)


@pytest.mark.parametrize("seed,yaw_deg", [(0, 0.0), (1, 75.0), (2, 180.0), (3, -120.0)])
def test_roman_recovers_transform_and_true_associations(seed: int, yaw_deg: float) -> None:
    T = pose_4dof(4.0, -3.0, 0.5, np.deg2rad(yaw_deg))
    a, b, truth = make_submap_pair(seed, 12, 12, 12, T_a_b=T, noise_m=0.05)  # 50 % outliers
    r = build_aligner("roman").align(a.public(), b.public())
    assert _correct(r, T)
    got, true = set(map(tuple, r.associations)), set(map(tuple, truth))
    assert got <= true and len(got) >= 10
    assert r.info["n_putative"] < len(a) * len(b)  # semantics pruned impossible pairs
    assert r.scores.shape == (len(got),) and (r.scores > 0).all() and r.runtime_s > 0


def test_aligning_b_to_a_gives_the_inverse() -> None:
    T = pose_4dof(-2.0, 5.0, 0.3, np.deg2rad(140.0))
    a, b, _ = make_submap_pair(5, 12, 8, 8, T_a_b=T, noise_m=0.05)
    al = build_aligner("roman")
    ab, ba = al.align(a, b), al.align(b, a)
    rot, trans = pose_error(ba.T_a_b, inv_T(ab.T_a_b))
    assert np.rad2deg(rot) < 0.5 and trans < 0.05
    assert set(map(tuple, ab.associations)) == set(map(tuple, ba.associations[:, ::-1]))


def test_semantics_break_the_tie_of_repeated_layouts() -> None:
    a, b, truth = make_submap_pair(3, 10, 0, 0, noise_m=0.0, repeated_layout=True)
    ids_a, ids_b = a.truth.object_ids, b.truth.object_ids
    decoy = np.array([[np.flatnonzero(ids_a == 1000 + ids_b[j])[0], j] for j in truth[:, 1]])
    # geometry alone: the true and the decoy clique are equally dense (an exact tie)
    all_pairs = np.array([(i, j) for i in range(len(a)) for j in range(len(b))])
    A = _prepare(build_affinity(a.centers, b.centers, all_pairs, None, GravityParams()))
    index = {tuple(p): k for k, p in enumerate(all_pairs)}
    d_true = clique_density(A, np.array([index[tuple(p)] for p in truth]))
    d_decoy = clique_density(A, np.array([index[tuple(p)] for p in decoy]))
    assert d_true == pytest.approx(d_decoy, rel=1e-9) and d_true > 9
    # with semantics the decoy associations are not even putative
    r = build_aligner("roman").align(a, b)
    assert _correct(r, b.truth.T_world_submap)
    assert set(map(tuple, r.associations)) == set(map(tuple, truth))


def test_geometry_only_is_fooled_by_some_repeated_layouts() -> None:
    wrong = 0
    for seed in range(5):
        a, b, _ = make_submap_pair(seed, 10, 5, 5, noise_m=0.05, repeated_layout=True)
        assert _correct(build_aligner("roman").align(a, b), b.truth.T_world_submap)
        wrong += not _correct(build_aligner("gravity").align(a, b), b.truth.T_world_submap)
    assert wrong >= 1


# visual aligns submaps by their keyframes, which synthetic segment submaps do not have
# (tests/align/visual covers it on rendered frames)
@pytest.mark.parametrize(
    "name", [n for n in ALIGNERS.names() if (n != "kiss_matcher" or find_spec("kiss_matcher")) and n != "visual"]
)
def test_every_method_returns_a_valid_result(name: str) -> None:
    T = pose_4dof(3.0, 2.0, 0.2, np.deg2rad(30.0))
    a, b, truth = make_submap_pair(8, 12, 6, 6, T_a_b=T, noise_m=0.05, descriptor_dim=64)
    r = build_aligner(name, FAST.get(name)).align(a, b)
    assert isinstance(r, AlignResult) and r.method == name
    assert r.associations.ndim == 2 and r.associations.shape[1] == 2
    assert len(r.scores) == len(r.associations) and r.runtime_s >= 0
    assert "n_putative" in r.info
    if r.ok:
        assert r.T_a_b.shape == (4, 4) and r.reason is None
        assert (r.associations[:, 0] < len(a)).all() and (r.associations[:, 1] < len(b)).all()
    else:
        assert r.reason
    if name not in ("ransac100k",):  # 100k hypotheses can miss on 324 correspondences
        assert _correct(r, T), (name, r.reason)


def _bad_pairs() -> dict[str, tuple]:
    a, b, _ = make_submap_pair(1, 6, 2, 2, descriptor_dim=16)
    nan_desc = a.descriptors.copy()
    nan_desc[2, 3] = np.nan
    zero_desc = a.descriptors.copy()
    zero_desc[1] = 0.0
    line = np.outer(np.arange(len(a), dtype=float), [1.0, 0.5, 0.1])
    return {
        "two segments": (
            replace(
                a,
                centers=a.centers[:2],
                volumes=a.volumes[:2],
                shape=a.shape[:2],
                descriptors=a.descriptors[:2],
                extents=a.extents[:2],
            ),
            b,
        ),
        "identical centres": (replace(a, centers=np.ones_like(a.centers)), b),
        "collinear centres": (replace(a, centers=line), b),
        "nan centre": (replace(a, centers=np.where(np.eye(len(a), 3, dtype=bool), np.nan, a.centers)), b),
        "nan descriptors": (replace(a, descriptors=nan_desc), b),
        "zero descriptors": (a, replace(b, descriptors=np.zeros_like(b.descriptors))),
        "zero descriptor row": (replace(a, descriptors=zero_desc), b),
        "descriptor sizes": (a, replace(b, descriptors=b.descriptors[:, :8])),
    }


@pytest.mark.parametrize("case", list(_bad_pairs()))
def test_bad_input_gives_no_alignment_with_a_reason(case: str) -> None:
    a, b = _bad_pairs()[case]
    semantic_cases = {"nan descriptors", "zero descriptors", "zero descriptor row", "descriptor sizes"}
    for name in ["roman", "clipper_prune", "semantic_gravity", "clipper", "ransac100k"]:
        r = build_aligner(name).align(a, b)
        uses_semantics = name in ("roman", "clipper_prune", "semantic_gravity")
        if case in semantic_cases and not uses_semantics:
            continue  # methods blind to descriptors ignore them
        assert not r.ok and r.reason, (name, case)


def test_build_aligner_errors_and_user_classes() -> None:
    with pytest.raises(ConfigError, match="roman") as err:
        build_aligner("romann")
    assert "ransac1m" in str(err.value)
    with pytest.raises(ConfigError, match="sigmaa"):
        build_aligner("roman", {"sigmaa": 0.3})
    with pytest.raises(ConfigError, match="sigma"):
        build_aligner("roman", {"sigma": -1.0})
    with pytest.raises(ConfigError, match="fusion"):
        build_aligner("roman", {"fusion": "median"})
    user = build_aligner("roman_sim.align.aligners:RomanAligner", {"sigma": 0.3})
    assert user.params.sigma == 0.3
    with pytest.raises(ConfigError, match="align"):
        build_aligner("roman_sim.core.geometry:make_T")


def test_variant_defaults_follow_the_reference() -> None:
    assert build_aligner("clipper").params.gravity is False
    assert build_aligner("clipper_prune").params.max_roll_pitch_deg == 5.0
    p = build_aligner("roman").params
    assert (p.sigma, p.epsilon, p.mindist, p.cos_min, p.cos_max, p.fusion) == (0.4, 0.6, 0.2, 0.85, 1.0, "geometric")
    assert p.min_associations_for_transform == 3 and p.max_roll_pitch_deg == 90.0
    assert build_aligner("ransac1m").params.iterations == 1_000_000
    assert build_aligner("shape_gravity").params.use_semantics is False


def test_kiss_matcher_peer() -> None:
    pytest.importorskip("kiss_matcher")
    T = pose_4dof(3.0, 2.0, 0.2, np.deg2rad(60.0))
    a, b, truth = make_submap_pair(8, 10, 4, 4, T_a_b=T, noise_m=0.03, descriptor_dim=16)
    r = build_aligner("kiss_matcher").align(a, b)
    assert _correct(r, T), r.reason
    assert set(map(tuple, r.associations)) == set(map(tuple, truth))


def test_kiss_matcher_missing_extra_is_a_config_error(monkeypatch: pytest.MonkeyPatch) -> None:
    import roman_sim.align.peers as peers

    monkeypatch.setattr(peers.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(ConfigError, match="peers"):
        build_aligner("kiss_matcher")


@pytest.mark.parametrize(
    "params",
    [{"dof": 4}, {"weighted": True}, {"fusion": "arithmetic"}, {"fusion": "product"}, {"gravity_uncertainty_deg": 5.0}],
)
def test_roman_options_still_recover_the_transform(params: dict) -> None:
    T = pose_4dof(-3.0, 1.0, 0.4, np.deg2rad(-150.0))
    a, b, truth = make_submap_pair(9, 12, 12, 12, T_a_b=T, noise_m=0.05, descriptor_dim=64)
    r = build_aligner("roman", params).align(a, b)
    assert _correct(r, T)
    assert set(map(tuple, r.associations)) <= set(map(tuple, truth))
    if params.get("dof") == 4:
        np.testing.assert_allclose(r.T_a_b[2, :3], [0.0, 0.0, 1.0], atol=1e-12)


def test_same_input_same_result() -> None:
    a, b, _ = make_submap_pair(4, 12, 12, 12, descriptor_dim=64)
    r1, r2 = build_aligner("clipper").align(a, b), build_aligner("clipper").align(a, b)
    np.testing.assert_array_equal(r1.T_a_b, r2.T_a_b)
    np.testing.assert_array_equal(r1.associations, r2.associations)
    np.testing.assert_array_equal(r1.scores, r2.scores)


def test_tilted_result_is_rejected_by_the_pruned_baseline() -> None:
    from roman_sim.core.geometry import make_T, rpy_to_R

    T = make_T(rpy_to_R(np.deg2rad(10.0), 0.0, 0.5), [1.0, 2.0, 0.0])
    a, b, _ = make_submap_pair(6, 12, 4, 4, T_a_b=T, noise_m=0.02, descriptor_dim=64)
    assert _correct(build_aligner("clipper").align(a, b), T)  # 6-DoF, 90 deg limit
    r = build_aligner("clipper_prune").align(a, b)
    assert not r.ok and "roll/pitch" in r.reason and r.n_associations >= 3


def test_users_can_register_their_own_method(monkeypatch: pytest.MonkeyPatch) -> None:
    class Identity:
        name = "identity"

        def __init__(self, scale: float = 1.0) -> None:
            self.scale = scale

        def align(self, a, b) -> AlignResult:
            return AlignResult(self.name, np.eye(4), np.zeros((0, 2), np.int64), np.zeros(0), 0.0)

    monkeypatch.setitem(ALIGNERS._items, "identity", Identity)
    al = build_aligner("identity", {"scale": 2.0})
    assert al.scale == 2.0 and al.align(None, None).ok
    with pytest.raises(ConfigError, match="bad parameters"):
        build_aligner("identity", {"nope": 1})
