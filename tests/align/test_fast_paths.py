"""The aligners' fast paths against their plain definitions.

RANSAC draws only the hypotheses that pass the first edge check (same distribution as
drawing every triple); CLIPPER multiplies with scipy's CSR kernel directly (same bits as
``csr_matrix @ v``), and its compiled solver gives the numpy solver's bits on the solver
tests' graphs and on affinity matrices of submap pairs.
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
    from roman_sim.align.clipper_rounding import _dense_rows

    A = sp.random(40, 40, density=0.15, format="csr", random_state=7)
    rows = np.array([5, 0, 33, 5])
    np.testing.assert_array_equal(_dense_rows(A, rows), A[rows].toarray())


def test_edgeless_graph_shortcut_matches_the_full_ascent() -> None:
    from roman_sim.align.clipper import ClipperParams, _ascend, _Pattern, _penalty_step, solve_clipper
    from roman_sim.align.clipper_rounding import round_solution
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
    from roman_sim.align.clipper_rounding import _sub_sum

    rng = np.random.default_rng(8)
    for _ in range(20):
        A = sp.random(60, 60, density=0.3, format="csr", random_state=int(rng.integers(1000)))
        A = (A + A.T).tocsr()
        idx = rng.choice(60, int(rng.integers(1, 30)), replace=False)
        assert _sub_sum(A, idx) == float(A[idx][:, idx].sum())
        assert _sub_sum(A, list(idx)) == float(A[list(idx)][:, list(idx)].sum())


# ---- the compiled CLIPPER against the numpy path ------------------------------------------------
def _same_solution(a, b) -> None:
    """Identical to the last bit: vector, objective, density, steps and selection."""
    np.testing.assert_array_equal(a.u, b.u)
    np.testing.assert_array_equal(a.selected, b.selected)
    assert (a.F, a.density, a.iterations) == (b.F, b.density, b.iterations)


def _regression_problems() -> list:
    """The solver tests' graphs (random weighted with a planted clique, unweighted planted,
    two cliques) and the affinity matrices of synthetic submap pairs (400 and 1600 associations)."""
    import itertools

    from roman_sim.align.affinity import build_affinity, object_scores
    from roman_sim.align.aligners import ClipperBaselineParams, RomanParams
    from roman_sim.align.synthetic import make_submap_pair

    from .test_clipper import _random_graph

    rng = np.random.default_rng(2024)
    out = [sp.csr_matrix(_random_graph(rng)) for _ in range(120)]
    planted = np.triu(np.random.default_rng(7).random((60, 60)) < 0.1, 1).astype(float)
    planted = planted + planted.T
    planted[np.ix_(range(10, 22), range(10, 22))] = 1.0
    two = np.zeros((7, 7))
    two[np.ix_([0, 1, 2], [0, 1, 2])], two[np.ix_([3, 4, 5, 6], [3, 4, 5, 6])] = 0.5, 0.9
    out += [sp.csr_matrix(planted), two]
    for n, seed in itertools.product((20, 40), range(3)):
        a, b, _ = make_submap_pair(seed, n // 2, n // 2, n // 2, noise_m=0.05, descriptor_dim=8)
        assoc = np.array([(i, j) for i in range(n) for j in range(n)])
        out.append(build_affinity(a.centers, b.centers, assoc, None, ClipperBaselineParams()))
        p = RomanParams()
        s_o = object_scores(a, b, p)
        ia, ib = np.nonzero(s_o > 0)
        out.append(build_affinity(a.centers, b.centers, np.stack([ia, ib], 1), s_o[ia, ib], p))
    return out


def test_compiled_clipper_gives_the_numpy_solvers_bits() -> None:
    from roman_sim.align.clipper import ClipperParams, _compiled, solve_clipper, solve_clipper_numpy

    assert _compiled() is not None, "numba is a dependency: the compiled solver must build"
    problems = _regression_problems()
    for M in problems:
        _same_solution(solve_clipper(M), solve_clipper_numpy(M))
    _same_solution(
        solve_clipper(problems[0], ClipperParams(seed=3)), solve_clipper_numpy(problems[0], ClipperParams(seed=3))
    )
    # tight budgets: line searches that run out, few outer iterations
    budget = ClipperParams(maxoliters=2, maxiniters=3, maxlsiters=2, beta=0.5)
    for M in problems[-4:]:
        _same_solution(solve_clipper(M, budget), solve_clipper_numpy(M, budget))


def test_compiled_sums_and_dots_are_numpys() -> None:
    from roman_sim.align import clipper_jit

    rng = np.random.default_rng(9)
    for n in [*range(0, 300), 511, 512, 513, 1023, 1024, 1025, 4097, 20001, 100003]:
        x = rng.standard_normal(n) * 10.0 ** rng.uniform(-8, 8, n)  # wide range: order matters
        y = rng.standard_normal(n)
        assert clipper_jit.total(x) == x.sum() and clipper_jit.dot(x, y) == x @ y
        if n > 3:
            assert clipper_jit._pairwise(x, 3, n - 3) == x[3:].sum()


def test_start_vector_is_the_streams_prefix() -> None:
    from roman_sim.align.clipper import _start
    from roman_sim.core.seeding import child_rng

    for seed, n in ((0, 1), (0, 400), (0, 4097), (5, 9000), (0, 37)):
        np.testing.assert_array_equal(_start(seed, n), child_rng(seed, "clipper", "u0").random(n) + 0.5)
