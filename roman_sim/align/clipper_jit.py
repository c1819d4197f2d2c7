"""CLIPPER compiled with numba: the ascent and the rounding in one call each, with the numpy path's bits.

On the small problems of most submap pairs (hundreds of associations) the numpy solver
spends most of its time in per-call overhead: a dozen numpy calls per gradient step, each
about as long as the sparse product itself. This module runs the same arithmetic compiled
and in the same order, so the solution is the same to the last bit:

- sums are numpy's pairwise summation (``_pairwise``: eight partial sums up to 128 elements,
  halves above), which ``ndarray.sum`` uses on contiguous data;
- dot products call the very ``ddot`` numpy's ``dot`` calls, found in the BLAS library numpy
  is linked to;
- sparse products are scipy's CSR loop (each row summed left to right from 0.0);
- element-wise steps keep the numpy expressions' order of operations.

``usable()`` is False when numba is missing, numpy's ``ddot`` cannot be found, or the
check of ``dot`` and ``total`` against numpy (vectors of several lengths) fails; the solver
then runs the numpy path. Written by hand: no library offers a sparse CLIPPER ascent
without per-iteration Python overhead. Compiled code is cached by numba (``cache=True``).
"""

from __future__ import annotations

import ctypes
import importlib
import logging
from typing import Any

import numpy as np
from numpy.typing import NDArray

log = logging.getLogger(__name__)
_SYMBOL = "roman_sim_clipper_ddot"
F64 = NDArray[np.float64]
#: CSR row pointers and column indices as the kernels take them (unsigned: see ``strip``).
Ptr = NDArray[np.uint64]
Idx = NDArray[np.uint32]


def _optional(name: str) -> Any:
    """The module ``name``, or None when it cannot be imported."""
    try:
        return importlib.import_module(name)
    except ImportError:  # numba is a dependency; without it the numpy path runs
        return None


numba: Any = _optional("numba")


def _numpy_ddot() -> tuple[int, bool] | None:
    """Address of the ``ddot`` numpy's ``dot`` calls, and whether it takes 64-bit integers."""
    core = _optional("numpy._core._multiarray_umath") or _optional("numpy.core._multiarray_umath")
    if core is None:  # pragma: no cover - a numpy without its extension module
        return None
    try:
        lib = ctypes.CDLL(core.__file__)
    except OSError:  # pragma: no cover - an extension that cannot be opened by path
        return None
    for name, ilp64 in (("scipy_cblas_ddot64_", True), ("cblas_ddot64_", True), ("cblas_ddot", False)):
        fn = getattr(lib, name, None)
        if fn is not None:
            address = ctypes.cast(fn, ctypes.c_void_p).value
            return (address, ilp64) if address else None
    return None


def _ddot_type() -> Any:
    """The numba type of numpy's ``ddot`` (registered under ``_SYMBOL``), or None."""
    if numba is None:
        return None
    found = _numpy_ddot()
    if found is None:
        return None
    import llvmlite.binding as llvm

    llvm.add_symbol(_SYMBOL, found[0])
    nt = numba.types
    int_t = nt.int64 if found[1] else nt.int32
    return nt.ExternalFunction(_SYMBOL, nt.float64(int_t, nt.voidptr, int_t, nt.voidptr, int_t))


_ddot = _ddot_type()
_jit: Any = numba.njit(cache=True, nogil=True) if numba is not None else (lambda f: f)


# ---- numpy's arithmetic ----------------------------------------------------------------
@_jit
def _block(a: F64, lo: int, n: int) -> float:
    """numpy's sum of at most 128 elements ``a[lo:lo + n]``: eight partial sums, then the rest."""
    if n < 8:
        r = 0.0
        for i in range(lo, lo + n):
            r += a[i]
        return r
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i, m = 8, n - n % 8
    while i < m:
        j = lo + i
        r0 += a[j]
        r1 += a[j + 1]
        r2 += a[j + 2]
        r3 += a[j + 3]
        r4 += a[j + 4]
        r5 += a[j + 5]
        r6 += a[j + 6]
        r7 += a[j + 7]
        i += 8
    r = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        r += a[lo + i]
        i += 1
    return r


@_jit
def _pairwise(a: F64, lo: int, n: int) -> float:
    """numpy's pairwise sum of ``a[lo:lo + n]`` (bit for bit).

    Above 128 elements numpy adds the sums of two halves (the first rounded down to a
    multiple of 8), recursively; this walks that tree with an explicit stack (numba cannot
    cache recursive functions).
    """
    if n <= 128:
        return _block(a, lo, n)
    s_lo, s_n, s_phase = np.empty(64, np.int64), np.empty(64, np.int64), np.zeros(64, np.int64)
    vals = np.empty(64)
    top, nv = 0, 0
    s_lo[0], s_n[0] = lo, n
    while top >= 0:
        lo_t, n_t = s_lo[top], s_n[top]
        if n_t <= 128:
            vals[nv] = _block(a, lo_t, n_t)
            nv += 1
            top -= 1
            continue
        half = n_t // 2 - (n_t // 2) % 8
        phase = s_phase[top]
        s_phase[top] = phase + 1
        if phase < 2:  # push the first half, then the second
            top += 1
            s_lo[top], s_n[top], s_phase[top] = (lo_t, half, 0) if phase == 0 else (lo_t + half, n_t - half, 0)
        else:  # both halves summed: combine them, first + second
            nv -= 1
            vals[nv - 1] = vals[nv - 1] + vals[nv]
            top -= 1
    return vals[0]


@_jit
def total(a: F64) -> float:
    """``a.sum()`` of a contiguous 1-D array."""
    return _pairwise(a, 0, a.shape[0])


@_jit
def dot(x: F64, y: F64) -> float:
    """``x @ y`` of contiguous 1-D arrays, by numpy's own ``ddot``."""
    return _ddot(x.shape[0], x.ctypes.data, 1, y.ctypes.data, 1)


@_jit
def _matvec(indptr: Ptr, indices: Idx, w: F64, v: F64, y: F64) -> None:
    """``y = W v`` for weights ``w`` on the CSR pattern (scipy's ``csr_matvec`` from zeros)."""
    for i in range(y.shape[0]):
        s = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            s += w[jj] * v[indices[jj]]
        y[i] = s


@_jit
def _pattern_matvec(indptr: Ptr, indices: Idx, v: F64, y: F64) -> None:
    """``y = C v`` for the 0/1 pattern (weights 1.0: the same bits as multiplying by ones)."""
    for i in range(y.shape[0]):
        s = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            s += v[indices[jj]]
        y[i] = s


# ---- the ascent ------------------------------------------------------------------------
@_jit
def strip(indptr: NDArray[np.integer], indices: NDArray[np.integer], data: F64) -> tuple[Ptr, Idx, F64, bool]:
    """CSR without its diagonal and its zero entries; False when an entry is not finite or negative.

    The index arrays come back unsigned (``uint64`` row pointers, ``uint32`` columns: fewer
    than 2**32 rows): numba then needs no negative-index wrap-around in the products, which
    makes them about twice as fast.
    """
    n = indptr.shape[0] - 1
    ok = True
    for x in data:
        if not (np.isfinite(x) and x >= 0.0):
            ok = False
    new_ptr = np.zeros(n + 1, dtype=np.uint64)
    new_idx = np.empty(data.shape[0], dtype=np.uint32)
    new_dat = np.empty(data.shape[0], dtype=np.float64)
    k = 0
    for i in range(n):
        for jj in range(indptr[i], indptr[i + 1]):
            if indices[jj] != i and data[jj] > 0:
                new_idx[k] = indices[jj]
                new_dat[k] = data[jj]
                k += 1
        new_ptr[i + 1] = k
    return new_ptr, new_idx[:k], new_dat[:k], ok


@_jit
def _penalty_step(indptr: Ptr, indices: Idx, data: F64, u: F64, eps: float, y: F64, z: F64) -> float:
    """Mean of (M u) / (Cbar u) over nodes with support and non-edge mass (0 if none)."""
    s = total(u)
    _pattern_matvec(indptr, indices, u, y)
    n, count = u.shape[0], 0
    for i in range(n):
        y[i] = (s - y[i]) - u[i]  # Cbar u
        if y[i] > eps and u[i] > eps:
            count += 1
    if count == 0:
        return 0.0
    _matvec(indptr, indices, data, u, z)
    vals = np.empty(count)
    k = 0
    for i in range(n):
        if y[i] > eps and u[i] > eps:
            vals[k] = abs((z[i] + u[i]) / y[i])
            k += 1
    return total(vals) / count


@_jit
def _grad(indptr: Ptr, indices: Idx, G: F64, c1: float, d: float, v: F64, out: F64, y: F64) -> None:
    """``out = (1 + d) v - d 1(1^T v) + G v``, in that order."""
    ds = d * total(v)
    _matvec(indptr, indices, G, v, y)
    for i in range(v.shape[0]):
        out[i] = (c1 * v[i] - ds) + y[i]


@_jit
def _ascend(
    indptr: Ptr, indices: Idx, G: F64, d: float, u: F64, prm: tuple[float, ...], bufs: tuple[F64, F64, F64, F64]
) -> tuple[F64, float, int]:
    """Inner projected gradient ascent at penalty ``d`` (the numpy path's ``_ascend``)."""
    tol_u, tol_F, maxiniters, maxlsiters, beta, eps = prm
    g, un, gn, y = bufs
    n, c1 = u.shape[0], 1.0 + d
    _grad(indptr, indices, G, c1, d, u, g, y)
    F, steps, Fn = dot(u, g), 0, 0.0
    for _ in range(int(maxiniters)):
        alpha, accepted = 1.0, False
        for _ in range(int(maxlsiters)):
            for i in range(n):
                x = u[i] + g[i] if alpha == 1.0 else u[i] + alpha * g[i]
                un[i] = x if (x > 0.0 or np.isnan(x)) else 0.0
            nrm = np.sqrt(dot(un, un))
            if nrm <= eps:
                alpha *= beta
                continue
            for i in range(n):
                un[i] /= nrm
            _grad(indptr, indices, G, c1, d, un, gn, y)
            Fn = dot(un, gn)
            if Fn - F >= -eps:
                accepted = True
                break
            alpha *= beta
        if not accepted:
            break
        steps += 1
        for i in range(n):
            y[i] = un[i] - u[i]
        du, dF = np.sqrt(dot(y, y)), abs(Fn - F)
        u, un = un, u
        g, gn = gn, g
        F = Fn
        if du < tol_u or dF < tol_F:
            break
    return u, F, steps


@_jit
def ascent(
    indptr: Ptr, indices: Idx, data: F64, u0: F64, prm: tuple[float, ...], maxoliters: int
) -> tuple[F64, float, int]:
    """Start vector, penalty schedule and inner ascents; returns (u, u^T (M u), gradient steps)."""
    n = u0.shape[0]
    y, z = np.zeros(n), np.zeros(n)
    _matvec(indptr, indices, data, u0, y)
    u = np.empty(n)
    for i in range(n):
        u[i] = y[i] + u0[i]
    nrm = np.sqrt(dot(u, u))
    for i in range(n):
        u[i] /= nrm
    eps = prm[5]
    bufs = (np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n))
    d = _penalty_step(indptr, indices, data, u, eps, y, z)
    steps_total = 0
    for _ in range(maxoliters):
        G = data + d
        u, _, steps = _ascend(indptr, indices, G, d, u, prm, bufs)
        u = u.copy()  # the ascent's buffers are reused; keep this iterate
        steps_total += steps
        dd = _penalty_step(indptr, indices, data, u, eps, y, z)
        if dd <= 0:
            break
        d += dd
    _matvec(indptr, indices, data, u, y)
    for i in range(n):
        z[i] = y[i] + u[i]
    return u, dot(u, z), steps_total


def usable() -> bool:
    """Whether the compiled kernels run here and give numpy's bits (``dot``, ``total`` checked)."""
    if numba is None or _ddot is None:
        return False
    rng = np.random.default_rng(0)
    for n in (0, 1, 7, 8, 9, 100, 128, 129, 1000, 4099):
        x, y = rng.standard_normal(n) * 1e3, rng.standard_normal(n) ** 3
        if dot(x, y) != x @ y or total(x) != x.sum():
            log.warning("compiled CLIPPER disagrees with numpy here; using the numpy solver")
            return False
    return True
