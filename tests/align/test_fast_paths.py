"""The aligners' fast paths against their plain definitions.

RANSAC draws only the hypotheses that pass the first edge check (same distribution as
drawing every triple); CLIPPER multiplies with scipy's CSR kernel directly (same bits as
``csr_matrix @ v``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial.distance import cdist

from roman_sim.align.clipper import _Pattern
from roman_sim.align.ransac import _ratio_ok, _sample, compatible_edges


def _centres(rng: np.random.Generator, n: int) -> np.ndarray:
    c = rng.uniform(-12, 12, (n, 3))
    c[1] = c[0]  # two coincident centres: zero lengths must fail the check
    return c


def test_compatible_edges_equal_brute_force() -> None:
    rng = np.random.default_rng(3)
    Da, Db = cdist(*[_centres(rng, 9)] * 2), cdist(*[_centres(rng, 11)] * 2)
    ea, eb = compatible_edges(Da, Db, 0.95)
    la, lb = Da.ravel(), Db.ravel()
    A, B = np.meshgrid(np.arange(len(la)), np.arange(len(lb)), indexing="ij")
    ok = _ratio_ok(la[A.ravel()], lb[B.ravel()], 0.95)
    brute = set(zip(A.ravel()[ok].tolist(), B.ravel()[ok].tolist()))
    assert set(zip(ea.tolist(), eb.tolist())) == brute and len(ea) == len(brute) > 0


def test_sampled_triples_pass_every_edge_at_the_rate_of_full_draws() -> None:
    rng = np.random.default_rng(4)
    ca, cb = _centres(rng, 10), _centres(rng, 12)
    Da, Db = cdist(ca, ca), cdist(cb, cb)
    k, ratio = 400_000, 0.9
    ia, ib = _sample(np.random.default_rng(0), 10, 12, k, Da, Db, ratio, compatible_edges(Da, Db, ratio))
    for s, t in ((0, 1), (1, 2), (0, 2)):  # every returned triple passes all three checks
        assert _ratio_ok(Da[ia[:, s], ia[:, t]], Db[ib[:, s], ib[:, t]], ratio).all()
    # the plain sampler: k uniform triples, all three edges checked
    full_a, full_b = rng.integers(0, 10, (k, 3)), rng.integers(0, 12, (k, 3))
    ok = np.ones(k, bool)
    for s, t in ((0, 1), (1, 2), (0, 2)):
        ok &= _ratio_ok(Da[full_a[:, s], full_a[:, t]], Db[full_b[:, s], full_b[:, t]], ratio)
    p = ok.mean()
    sigma = np.sqrt(2 * k * p * (1 - p))  # difference of two binomial counts
    assert p > 0.001 and abs(len(ia) - ok.sum()) < 5 * sigma
    # the first correspondence of a surviving triple is uniform over what passes: compare histograms
    h_fast = np.bincount(ia[:, 0], minlength=10) / len(ia)
    h_full = np.bincount(full_a[ok, 0], minlength=10) / ok.sum()
    assert np.abs(h_fast - h_full).max() < 0.02


def test_no_compatible_edge_draws_nothing() -> None:
    Da = cdist(np.eye(3) * [1.0, 2.0, 3.0], np.eye(3) * [1.0, 2.0, 3.0])
    Db = Da * 10.0
    edges = compatible_edges(Da, Db, 0.95)
    assert len(edges[0]) == 0
    ia, ib = _sample(np.random.default_rng(0), 3, 3, 1000, Da, Db, 0.95, edges)
    assert ia.shape == (0, 3) and ib.shape == (0, 3)


def test_pattern_product_is_bit_identical_to_scipy() -> None:
    rng = np.random.default_rng(5)
    A = sp.random(60, 60, density=0.2, format="csr", random_state=6)
    A = (A + A.T).tocsr()
    v = rng.random(60)
    pat = _Pattern(A)
    np.testing.assert_array_equal(pat.mv(A.data, v), A @ v)
    np.testing.assert_array_equal(pat.mv(pat.ones, v), (A > 0).astype(float) @ v)


def test_dense_rows_equal_scipy_row_slicing() -> None:
    from roman_sim.align.clipper import _dense_rows

    A = sp.random(40, 40, density=0.15, format="csr", random_state=7)
    rows = np.array([5, 0, 33, 5])
    np.testing.assert_array_equal(_dense_rows(A, rows), A[rows].toarray())


def test_edgeless_graph_shortcut_matches_the_full_ascent() -> None:
    from roman_sim.align.clipper import ClipperParams, _ascend, _Pattern, _penalty_step, round_solution, solve_clipper
    from roman_sim.core.seeding import child_rng

    p = ClipperParams()
    for n in (1, 2, 7, 40, 170):
        A = sp.csr_matrix((n, n))
        u = child_rng(p.seed, "clipper", "u0").random(n) + 0.5
        u = u / np.linalg.norm(u)
        pat = _Pattern(A)
        d = _penalty_step(pat, A.data, u, p.eps)
        for _ in range(p.maxoliters):  # the general path, as solve_clipper runs it
            u, F, _ = _ascend(pat, A.data + d, d, u, p)
            dd = _penalty_step(pat, A.data, u, p.eps)
            if dd <= 0:
                break
            d += dd
        full = round_solution(A, u, float(u @ u), p.eps)
        assert solve_clipper(sp.identity(n, format="csr")).selected.tolist() == full.tolist()


def test_submatrix_sum_is_bit_identical_to_scipy() -> None:
    from roman_sim.align.clipper import _sub_sum

    rng = np.random.default_rng(8)
    for _ in range(20):
        A = sp.random(60, 60, density=0.3, format="csr", random_state=int(rng.integers(1000)))
        A = (A + A.T).tocsr()
        idx = rng.choice(60, int(rng.integers(1, 30)), replace=False)
        assert _sub_sum(A, idx) == float(A[idx][:, idx].sum())
        assert _sub_sum(A, list(idx)) == float(A[list(idx)][:, list(idx)].sum())
