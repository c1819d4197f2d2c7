"""CLIPPER: densest-subgraph search on a sparse weighted consistency graph (Lusk & How).

Maximises ``u^T M u / u^T u`` over ``u >= 0`` supported on a clique of ``C = (M > 0)`` by
projected gradient ascent with a growing penalty ``d`` on non-edges.
``M`` is a symmetric scipy sparse matrix with unit diagonal (the diagonal is treated as 1
whatever is stored). Everything per iteration is one sparse mat-vec plus O(n) work.

Rounding (``roman_sim.align.clipper_rounding``): the reference keeps the top ``round(F)``
entries of ``u``. With weights below 1 ``F`` underestimates the clique size, and the top
entries need not form a clique, so the selection is made a clique greedily (descending
``u``), extended by any node adjacent to every selected node whose addition raises the
clique density ``1^T M_S 1 / |S|``, and finally improved by single additions / one-for-one
swaps while the density rises. The
ascent itself is a local method: on small random weighted graphs it reaches the maximum
density clique about 95 % of the time (tests/align/test_clipper.py).

``solve_clipper`` runs the compiled solver (``roman_sim.align.clipper_jit``: the same
arithmetic in the same order, so the same bits) when numba can build it, else the numpy
path ``solve_clipper_numpy``; the fixed per-call costs of numpy on small vectors would
otherwise dominate the small problems of most submap pairs.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.align.clipper_rounding import clique_density, round_solution
from roman_sim.core.config import StrictModel
from roman_sim.core.errors import AlignmentError
from roman_sim.core.seeding import child_rng

try:  # scipy's own CSR kernel without the operator dispatch, which costs 2-3x the kernel at these sizes
    from scipy.sparse._sparsetools import csr_matvec as _csr_matvec
except ImportError:  # pragma: no cover - a scipy that moved it: the public operator gives the same result
    _csr_matvec = None

log = logging.getLogger(__name__)


class ClipperParams(StrictModel):
    """Solver settings (names follow the reference CLIPPER implementation)."""

    tol_u: float = Field(1e-8, gt=0, description="stop inner loop when |du| is below this")
    tol_F: float = Field(1e-9, gt=0, description="stop inner loop when |dF| is below this")
    maxoliters: int = Field(1000, ge=1, description="outer iterations (penalty increases)")
    maxiniters: int = Field(200, ge=1, description="gradient steps per outer iteration")
    maxlsiters: int = Field(99, ge=1, description="backtracking steps per gradient step")
    beta: float = Field(0.25, gt=0, lt=1, description="backtracking factor")
    eps: float = Field(1e-9, gt=0, description="numerical zero")
    seed: int = Field(0, ge=0, description="seed of the random initial vector")


@dataclass
class ClipperSolution:
    """Result of :func:`solve_clipper`.

    Attributes:
        u: (n,) final non-negative unit vector.
        selected: (k,) sorted indices of the selected clique.
        F: final objective ``u^T M u`` (estimate of the clique size).
        density: ``1^T M_S 1 / |S|`` of the selected set (0 when empty).
        iterations: total gradient steps taken.
    """

    u: NDArray[np.float64]
    selected: NDArray[np.int64]
    F: float
    density: float
    iterations: int


def _as_csr(M: sp.spmatrix | NDArray[np.floating]) -> sp.csr_matrix:
    """``M`` as a square float64 CSR matrix (not copied when it is one)."""
    if isinstance(M, (sp.csr_matrix, sp.csr_array)) and M.dtype == np.float64:
        A = M
    else:
        A = sp.csr_matrix(M, dtype=np.float64)
    if A.shape[0] != A.shape[1]:
        raise AlignmentError(f"affinity matrix must be square, got shape {A.shape}")
    return A


def _prepare(M: sp.spmatrix | NDArray[np.floating]) -> sp.csr_matrix:
    """Square, finite, non-negative CSR of ``M`` without its diagonal (entries assumed unique)."""
    A = _as_csr(M)
    if A.nnz and (not np.all(np.isfinite(A.data)) or A.data.min() < 0):
        raise AlignmentError("affinity matrix entries must be finite and >= 0")
    row = np.repeat(np.arange(A.shape[0], dtype=A.indices.dtype), np.diff(A.indptr))
    keep = (A.indices != row) & (A.data > 0)
    indptr = np.zeros(A.shape[0] + 1, dtype=A.indptr.dtype)
    np.cumsum(np.bincount(row[keep], minlength=A.shape[0]), out=indptr[1:])
    return sp.csr_matrix((A.data[keep], A.indices[keep], indptr), shape=A.shape)


class _Pattern:
    """The sparsity pattern of a CSR matrix: products ``W v`` for weights ``W`` on that pattern.

    The ascent takes a few hundred mat-vecs per pair of submaps on small matrices, where
    scipy's operator overhead exceeds the product itself; this calls scipy's CSR kernel
    directly (the same kernel, so the same bits as ``csr_matrix @ v``).
    """

    def __init__(self, A: sp.csr_matrix) -> None:
        self.n, self.indptr, self.indices = A.shape[0], A.indptr, A.indices
        self.ones = np.ones(len(A.data))

    def mv(self, data: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        """``W @ v`` with ``W`` the pattern's matrix holding ``data``."""
        if _csr_matvec is None:
            return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n)) @ v
        y = np.zeros(self.n)
        _csr_matvec(self.n, self.n, self.indptr, self.indices, data, v, y)
        return y


def _penalty_step(pat: _Pattern, data: NDArray[np.float64], u: NDArray[np.float64], eps: float) -> float:
    """Mean of (M u) / (Cbar u) over nodes with support and non-edge mass (0 if none)."""
    cbar_u = u.sum() - pat.mv(pat.ones, u) - u
    idx = (cbar_u > eps) & (u > eps)
    if not idx.any():
        return 0.0
    mu = (pat.mv(data, u) + u)[idx]
    return float(np.mean(np.abs(mu / cbar_u[idx])))


def _ascend(
    pat: _Pattern, G: NDArray[np.float64], d: float, u: NDArray[np.float64], p: ClipperParams
) -> tuple[NDArray[np.float64], float, int]:
    """Inner projected gradient ascent at penalty ``d``; ``G = M0 + d C0`` (weights on ``pat``).

    The gradient is ``(1 + d) v - d 1(1^T v) + G v``, evaluated in that order. The ascent runs
    a few hundred steps per pair of submaps on small vectors, where numpy's per-call overhead
    dominates: the step is written with as few calls as the arithmetic allows (same bits as
    the textbook form).
    """
    c1, eps, beta = 1.0 + d, p.eps, p.beta
    n, indptr, indices = pat.n, pat.indptr, pat.indices
    kernel = _csr_matvec
    sqrt, maximum, zeros = math.sqrt, np.maximum, np.zeros

    def grad(v: NDArray[np.float64]) -> NDArray[np.float64]:
        out = c1 * v
        out -= d * v.sum()
        if kernel is None:
            out += pat.mv(G, v)
        else:
            y = zeros(n)
            kernel(n, n, indptr, indices, G, v, y)
            out += y
        return out

    g = grad(u)
    F = float(u @ g)
    steps = 0
    for _ in range(p.maxiniters):
        alpha = 1.0
        for _ in range(p.maxlsiters):
            un = u + g if alpha == 1.0 else u + alpha * g
            maximum(un, 0.0, out=un)
            nrm = sqrt(un.dot(un))
            if nrm <= eps:
                alpha *= beta
                continue
            un /= nrm
            gn = grad(un)
            Fn = float(un @ gn)
            if Fn - F >= -eps:
                break
            alpha *= beta
        else:
            break
        steps += 1
        diff = un - u
        du = sqrt(diff.dot(diff))
        dF = abs(Fn - F)
        u, g, F = un, gn, Fn
        if du < p.tol_u or dF < p.tol_F:
            break
    return u, F, steps


@lru_cache(maxsize=8)
def _start_draws(seed: int, n: int) -> NDArray[np.float64]:
    """The first ``n`` uniform draws of the start vector's stream (a stream's prefix is its shorter draw)."""
    out = child_rng(seed, "clipper", "u0").random(n)
    out.flags.writeable = False
    return out


def _start(seed: int, n: int) -> NDArray[np.float64]:
    """``child_rng(seed, "clipper", "u0").random(n) + 0.5``, the draws cached in blocks of 4096."""
    return _start_draws(seed, -(-n // 4096) * 4096)[:n] + 0.5


@lru_cache(maxsize=1)
def _compiled() -> tuple[Any, Any] | None:
    """The compiled solver's modules (ascent, rounding), or None where they cannot run (numpy path)."""
    try:
        from roman_sim.align import clipper_jit, clipper_jit_rounding

        return (clipper_jit, clipper_jit_rounding) if clipper_jit.usable() else None
    except Exception as err:  # a failed build leaves the numpy path, which gives the same bits
        log.warning("compiled CLIPPER unavailable (%s: %s); using the numpy solver", type(err).__name__, err)
        return None


def warm_up() -> None:
    """Load the compiled solver (numba's cached machine code) now rather than on the first pair.

    Solves a 4-node complete graph, which runs every compiled kernel once; a process that
    forks workers after calling it spares each of them the loading.
    """
    solve_clipper(sp.csr_matrix(np.ones((4, 4))))


def solve_clipper(M: sp.spmatrix | NDArray[np.floating], params: ClipperParams | None = None) -> ClipperSolution:
    """Densest clique of the weighted consistency graph ``M``.

    Args:
        M: (n, n) symmetric non-negative affinities; ``M[p, q] > 0`` marks an edge.
        params: solver settings (defaults when None).

    Returns: the solution (the compiled solver's, bit for bit ``solve_clipper_numpy``'s);
    an empty graph gives an empty selection.
    """
    p = params or ClipperParams()
    jit = _compiled()
    if jit is None:
        return solve_clipper_numpy(M, p)
    asc, rnd = jit
    A = _as_csr(M)
    indptr, indices, data, ok = asc.strip(A.indptr, A.indices, A.data)
    if not ok:
        raise AlignmentError("affinity matrix entries must be finite and >= 0")
    n = A.shape[0]
    if n == 0 or len(data) == 0 or n >= 2**32:  # empty or edgeless: nothing to iterate
        return solve_clipper_numpy(M, p)
    prm = (p.tol_u, p.tol_F, float(p.maxiniters), float(p.maxlsiters), p.beta, p.eps)
    u, F, steps = asc.ascent(indptr, indices, data, _start(p.seed, n), prm, p.maxoliters)
    sel, density = rnd.round_and_score(indptr, indices, data, u, max(1, int(round(F))), p.eps)
    return ClipperSolution(u, sel, float(F), float(density), int(steps))


def solve_clipper_numpy(M: sp.spmatrix | NDArray[np.floating], params: ClipperParams | None = None) -> ClipperSolution:
    """``solve_clipper`` in numpy and scipy (the reference the compiled solver is tested against)."""
    p = params or ClipperParams()
    A = _prepare(M)
    n = A.shape[0]
    if n == 0:
        return ClipperSolution(np.zeros(0), np.zeros(0, dtype=np.int64), 0.0, 0.0, 0)
    pat = _Pattern(A)
    u = _start(p.seed, n)
    u = A @ u + u
    u /= np.linalg.norm(u)
    if A.nnz == 0:
        # No edge: the gradient (1 + d) u - d 1(1^T u) is increasing in each u_i, so the ascent
        # keeps the order of u and ends at the vertex of its largest entry; that vertex is the
        # selection whatever the penalties (the densest clique of an edgeless graph is one node).
        top = int(np.argmax(u))
        return ClipperSolution(np.eye(n)[top], np.array([top], dtype=np.int64), 1.0, 1.0, 0)
    d = _penalty_step(pat, A.data, u, p.eps)
    total = 0
    for _ in range(p.maxoliters):
        u, F, steps = _ascend(pat, A.data + d, d, u, p)
        total += steps
        dd = _penalty_step(pat, A.data, u, p.eps)
        if dd <= 0:
            break
        d += dd
    F = float(u @ (A @ u + u))
    selected = round_solution(A, u, F, p.eps)
    return ClipperSolution(u, selected, F, clique_density(A, selected), total)
