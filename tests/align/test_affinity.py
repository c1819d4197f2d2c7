"""Affinity formulas against hand-computed values and a brute-force consistency graph."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align.affinity import (
    AffinityParams,
    build_affinity,
    consistency_edges,
    object_scores,
    pairwise_consistency,
)
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.errors import ConfigError
from roman_sim.mapping.types import Submap

PLAIN = AffinityParams(gravity=False, use_shape=False, use_semantics=False)
GRAV = AffinityParams(gravity=True, use_shape=False, use_semantics=False)


def test_plain_score_hand_values() -> None:
    # lengths 5 and 5.3: c = 0.3 -> exp(-0.09 / 0.32)
    s = pairwise_consistency([3.0, 4.0, 0.0], [0.0, 5.3, 0.0], PLAIN)
    assert s == pytest.approx(np.exp(-0.09 / (2 * 0.16)))
    # plain form ignores direction: a vertical and a lateral pair of equal length agree
    assert pairwise_consistency([0, 0, 2.0], [2.0, 0, 0], PLAIN) == pytest.approx(1.0)
    assert pairwise_consistency([5.0, 0, 0], [5.7, 0, 0], PLAIN) == 0.0  # c > epsilon
    assert pairwise_consistency([0.1, 0, 0], [0.1, 0, 0], PLAIN) == 0.0  # below mindist


def test_gravity_score_hand_values() -> None:
    # lateral 5 vs 5.2, vertical +1 vs +0.9
    s = pairwise_consistency([3.0, 4.0, 1.0], [5.2, 0.0, 0.9], GRAV)
    expect = np.exp(-0.5 * (0.2**2 / (2 / 3 * 0.16) + 0.1**2 / (1 / 3 * 0.16)))
    assert s == pytest.approx(expect)
    # same 3D length but the vertical and lateral parts swapped: gravity rejects it
    assert pairwise_consistency([0, 0, 2.0], [2.0, 0, 0], GRAV) == 0.0
    # signed vertical differences are compared
    assert pairwise_consistency([2.0, 0, 0.3], [2.0, 0, -0.3], GRAV) == 0.0
    # gates: c_xy <= sqrt(2/3) * 0.6 = 0.4899, c_z <= sqrt(1/3) * 0.6 = 0.3464
    assert pairwise_consistency([5.0, 0, 0], [5.48, 0, 0], GRAV) > 0
    assert pairwise_consistency([5.0, 0, 0], [5.50, 0, 0], GRAV) == 0.0
    assert pairwise_consistency([5.0, 0, 0.0], [5.0, 0, 0.34], GRAV) > 0
    assert pairwise_consistency([5.0, 0, 0.0], [5.0, 0, 0.35], GRAV) == 0.0


def test_gravity_uncertainty_widening() -> None:
    p = GRAV.model_copy(update={"gravity_uncertainty_deg": 5.0})
    va, vb = np.array([10.0, 0, 2.0]), np.array([10.0, 0, 2.3])
    th = np.deg2rad(5.0)
    w_z = 2.15 * np.sin(th)
    w_xy = abs(10 * np.cos(th) - 10)
    s_z = np.sqrt(1 / 3) * 0.4 + w_z
    assert w_xy > 0  # lateral residual is 0 here, so only the vertical widening shows
    assert pairwise_consistency(va, vb, p) == pytest.approx(np.exp(-0.5 * (0.09 / s_z**2)))
    assert pairwise_consistency(va, vb, p) > pairwise_consistency(va, vb, GRAV)
    assert pairwise_consistency([10, 0, 2.0], [10, 0, 2.4], GRAV) == 0.0
    assert pairwise_consistency([10, 0, 2.0], [10, 0, 2.4], p) > 0.0  # gate widened too


def _submap(volumes, shape, desc) -> Submap:
    n = len(volumes)
    return Submap(
        robot="r",
        index=0,
        t=0.0,
        T_odom_submap=np.eye(4),
        segment_ids=np.arange(n),
        centers=np.zeros((n, 3)),
        volumes=np.asarray(volumes, float),
        shape=np.asarray(shape, float),
        descriptors=np.asarray(desc, np.float32),
        extents=np.ones((n, 3)),
    )


def test_object_scores_hand_values() -> None:
    a = _submap([2.0], [[0.5, 0.2, 0.1]], [[1.0, 0.0]])
    c = np.cos(np.deg2rad(20.0))  # cosine 0.9397
    b = _submap([1.0, 2.0], [[0.25, 0.2, 0.1], [0.5, 0.2, 0.1]], [[c, np.sin(np.deg2rad(20.0))], [0.0, 1.0]])
    shape = AffinityParams(use_semantics=False)
    np.testing.assert_allclose(object_scores(a, b, shape), [[(0.5 * 0.5) ** 0.25, 1.0]])
    sem = AffinityParams(use_shape=False)
    np.testing.assert_allclose(object_scores(a, b, sem), [[(c - 0.85) / 0.15, 0.0]], rtol=1e-6)
    both = AffinityParams()
    np.testing.assert_allclose(object_scores(a, b, both)[0, 0], np.sqrt(0.25**0.25 * (c - 0.85) / 0.15), rtol=1e-6)
    none = AffinityParams(use_shape=False, use_semantics=False)
    np.testing.assert_array_equal(object_scores(a, b, none), np.ones((1, 2)))


def test_cos_bounds_validated() -> None:
    with pytest.raises(ConfigError):
        from roman_sim.core.config import validate_model

        validate_model(AffinityParams, {"cos_min": 0.9, "cos_max": 0.8})


def _dense_reference(ca, cb, assoc, p):
    P = len(assoc)
    S = np.zeros((P, P))
    for x in range(P):
        for y in range(x + 1, P):
            (i, j), (k, m) = assoc[x], assoc[y]
            if i == k or j == m:
                continue
            S[x, y] = S[y, x] = pairwise_consistency(ca[i] - ca[k], cb[j] - cb[m], p)
    return S


@pytest.mark.parametrize("gravity,theta", [(False, 0.0), (True, 0.0), (True, 5.0)])
def test_consistency_edges_match_brute_force(gravity: bool, theta: float) -> None:
    a, b, _ = make_submap_pair(3, 6, 3, 3, noise_m=0.1, descriptor_dim=8)
    p = AffinityParams(gravity=gravity, gravity_uncertainty_deg=theta)
    rng = np.random.default_rng(0)
    ia, ib = np.nonzero(rng.random((len(a), len(b))) < 0.6)
    assoc = np.stack([ia, ib], 1)
    ref = _dense_reference(a.centers, b.centers, assoc, p)
    r, c, s = consistency_edges(a.centers, b.centers, ia, ib, p)
    got = np.zeros_like(ref)
    got[r, c] = s
    got = got + got.T
    np.testing.assert_allclose(got, ref, atol=1e-12)
    assert (r < c).all() and len(set(zip(r, c))) == len(r)


@pytest.mark.parametrize("fusion", ["geometric", "arithmetic", "product"])
def test_build_affinity_fusion_and_distinctness(fusion: str) -> None:
    ca = np.array([[0.0, 0, 0], [4.0, 0, 0], [0.0, 3.0, 0]])
    cb = ca.copy()
    assoc = np.array([[0, 0], [1, 1], [1, 2], [0, 1]])
    s_o = np.array([0.8, 0.5, 0.9, 0.7])
    M = build_affinity(ca, cb, assoc, s_o, AffinityParams(fusion=fusion)).toarray()
    np.testing.assert_array_equal(np.diag(M), 1.0)
    np.testing.assert_allclose(M, M.T)
    expect = {"geometric": (0.8 * 0.5) ** (1 / 3), "arithmetic": (1 + 0.8 + 0.5) / 3, "product": 0.8 * 0.5}[fusion]
    assert M[0, 1] == pytest.approx(expect)  # (0-0, 1-1): exact distances, s_a = 1
    assert M[1, 2] == 0 and M[0, 3] == 0  # share an object
    assert M[0, 2] == 0  # lengths 4 vs 3: inconsistent


def test_small_entries_dropped_and_no_object_score_means_s_a() -> None:
    ca = np.array([[0.0, 0, 0], [4.0, 0, 0]])
    cb = np.array([[0.0, 0, 0], [4.3, 0, 0]])
    assoc = np.array([[0, 0], [1, 1]])
    M = build_affinity(ca, cb, assoc, None, GRAV).toarray()
    assert M[0, 1] == pytest.approx(np.exp(-0.5 * 0.09 / (2 / 3 * 0.16)))
    tiny = build_affinity(ca, cb, assoc, np.array([1e-12, 1.0]), AffinityParams(fusion="product"))
    assert tiny.nnz == 2  # only the diagonal survives


def test_out_of_range_associations_raise_config_error() -> None:
    with pytest.raises(ConfigError):
        build_affinity(np.zeros((2, 3)), np.zeros((2, 3)), np.array([[0, 5]]), None, GRAV)
    with pytest.raises(ConfigError, match="duplicate"):
        build_affinity(np.zeros((2, 3)), np.zeros((2, 3)), np.array([[0, 1], [0, 1]]), None, GRAV)
