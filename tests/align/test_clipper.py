"""CLIPPER solver against brute-force maximum-density cliques on small random graphs."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.sparse as sp

from roman_sim.align.clipper import ClipperParams, solve_clipper
from roman_sim.core.errors import AlignmentError


def _brute_force_density(W: np.ndarray) -> float:
    """Max over cliques S of 1^T W_S 1 / |S| (unit diagonal)."""
    n, adj, best = len(W), W > 0, 0.0
    for r in range(1, n + 1):
        for S in itertools.combinations(range(n), r):
            idx = np.ix_(S, S)
            if not (adj[idx] | np.eye(r, dtype=bool)).all():
                continue
            best = max(best, (W[idx].sum() - np.trace(W[idx]) + r) / r)
    return best


def _random_graph(rng: np.random.Generator) -> np.ndarray:
    n = int(rng.integers(5, 12))
    W = np.triu((rng.random((n, n)) < rng.uniform(0.2, 0.7)) * rng.uniform(0.3, 1.0, (n, n)), 1)
    W = W + W.T
    S = rng.choice(n, int(rng.integers(3, 6)), replace=False)
    for a, b in itertools.permutations(S, 2):
        W[a, b] = W[b, a] = rng.uniform(0.6, 1.0)
    np.fill_diagonal(W, 1.0)
    return W


def test_matches_brute_force_on_random_weighted_graphs() -> None:
    """CLIPPER is a local method: documented >= 93 % exact, the rest within 25 %."""
    rng = np.random.default_rng(2024)
    ratios = []
    for _ in range(120):
        W = _random_graph(rng)
        sol = solve_clipper(sp.csr_matrix(W))
        sel = sol.selected
        assert (W[np.ix_(sel, sel)] > 0).all(), "selection must be a clique"
        ratios.append(sol.density / _brute_force_density(W))
    ratios = np.array(ratios)
    assert (ratios <= 1 + 1e-9).all()
    assert np.mean(ratios > 1 - 1e-9) >= 0.93
    assert ratios.min() >= 0.75


def test_unweighted_planted_clique_is_found_exactly() -> None:
    rng = np.random.default_rng(7)
    n, S = 60, np.arange(10, 22)
    A = np.triu(rng.random((n, n)) < 0.1, 1).astype(float)
    A = A + A.T
    A[np.ix_(S, S)] = 1.0
    np.fill_diagonal(A, 1.0)
    sol = solve_clipper(sp.csr_matrix(A))
    np.testing.assert_array_equal(sol.selected, S)
    assert sol.F == pytest.approx(12.0, abs=0.5)


def test_two_disjoint_cliques_picks_the_denser() -> None:
    W = np.zeros((7, 7))
    W[np.ix_([0, 1, 2], [0, 1, 2])] = 0.5
    W[np.ix_([3, 4, 5, 6], [3, 4, 5, 6])] = 0.9
    np.fill_diagonal(W, 1.0)
    sol = solve_clipper(W)
    np.testing.assert_array_equal(sol.selected, [3, 4, 5, 6])
    assert sol.density == pytest.approx((4 + 12 * 0.9) / 4)


def test_empty_and_edgeless_graphs() -> None:
    assert len(solve_clipper(sp.csr_matrix((0, 0))).selected) == 0
    sol = solve_clipper(sp.eye(5, format="csr"))
    assert len(sol.selected) == 1
    assert sol.density == pytest.approx(1.0)


def test_same_input_same_output() -> None:
    W = _random_graph(np.random.default_rng(3))
    a, b = solve_clipper(W, ClipperParams(seed=4)), solve_clipper(W, ClipperParams(seed=4))
    np.testing.assert_array_equal(a.u, b.u)


BAD = [np.ones((2, 3)), np.array([[1.0, -0.5], [-0.5, 1.0]]), np.array([[1.0, np.nan], [np.nan, 1.0]])]


@pytest.mark.parametrize("M", BAD)
def test_bad_matrices_raise_alignment_error(M: np.ndarray) -> None:
    with pytest.raises(AlignmentError):
        solve_clipper(M)


def test_input_matrix_is_not_modified() -> None:
    W = sp.csr_matrix(_random_graph(np.random.default_rng(5)))
    before = W.toarray().copy()
    solve_clipper(W)
    np.testing.assert_array_equal(W.toarray(), before)
