"""Consistency scores and the sparse affinity matrix of ROMAN.

- ``pairwise_consistency``: the geometric score s_a of two associations, plain (3D
  distance) or gravity-decoupled (lateral / vertical split), with the optional
  gravity-uncertainty widening.
- ``object_scores``: the per-association score s_o (shape ratios and rescaled semantic
  cosine) for all object pairs at once, an (n_a, n_b) matrix computed once per pair of
  submaps, so that descriptors are never touched per association pair.
- ``build_affinity``: all association pairs vectorised on object-level distance matrices,
  gated early, fused with s_o into a scipy CSR matrix with unit diagonal.

Fusion: the geometric gate decides the edges (s_a = 0 is never an edge, whatever the
fusion); without any object score, M = s_a as in standard CLIPPER. An association whose
s_o is 0 (cosine <= cos_min) is not a putative association at all.

Gravity-uncertainty widening: as ROMAN defines it, ``d_xy`` and ``d_z`` are
the mean (over the two submaps) lateral length and absolute vertical difference of the
pair; sigma and epsilon of each part are widened additively.
"""

from __future__ import annotations

import logging
from typing import Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from pydantic import Field, model_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError
from roman_sim.mapping.types import Submap

log = logging.getLogger(__name__)

Fusion = Literal["geometric", "arithmetic", "product"]
_XY, _Z = np.sqrt(2.0 / 3.0), np.sqrt(1.0 / 3.0)


class AffinityParams(StrictModel):
    """Parameters of the consistency graph (reference names)."""

    sigma: float = Field(0.4, gt=0, description="std of the distance residual (m)")
    epsilon: float = Field(0.6, gt=0, description="gate on the distance residual (m)")
    mindist: float = Field(0.2, ge=0, description="pairs of objects closer than this are not scored (m)")
    gravity: bool = Field(True, description="decouple lateral and vertical residuals")
    gravity_uncertainty_deg: float = Field(0.0, ge=0, le=45, description="theta of the widening; 0 = off")
    use_shape: bool = Field(True, description="shape ratios in s_o")
    use_semantics: bool = Field(True, description="semantic cosine in s_o")
    cos_min: float = Field(0.85, ge=-1, le=1, description="cosine at or below which s_o = 0")
    cos_max: float = Field(1.0, ge=-1, le=1, description="cosine at or above which the semantic term is 1")
    fusion: Fusion = Field("geometric", description="how s_a, s_o(p), s_o(q) fuse into M")
    min_affinity: float = Field(1e-4, ge=0, lt=1, description="entries <= this are dropped")

    @model_validator(mode="after")
    def _cos_order(self) -> "AffinityParams":
        if self.cos_max <= self.cos_min:
            raise ValueError(f"cos_max ({self.cos_max}) must be greater than cos_min ({self.cos_min})")
        return self


def _residual_score(c_xy: NDArray, c_z: NDArray, d_xy: NDArray, d_z: NDArray, p: AffinityParams) -> NDArray[np.float64]:
    """Gravity-decoupled score from lateral and vertical residuals (0 outside the gates)."""
    s_xy, e_xy, s_z, e_z = _XY * p.sigma, _XY * p.epsilon, _Z * p.sigma, _Z * p.epsilon
    if p.gravity_uncertainty_deg > 0:
        th = np.deg2rad(p.gravity_uncertainty_deg)
        w_xy, w_z = np.abs(d_xy * np.cos(th) - d_xy), np.abs(d_z * np.sin(th))
        s_xy, e_xy, s_z, e_z = s_xy + w_xy, e_xy + w_xy, s_z + w_z, e_z + w_z
    score = np.exp(-0.5 * (c_xy**2 / s_xy**2 + c_z**2 / s_z**2))
    return np.where((c_xy <= e_xy) & (c_z <= e_z), score, 0.0)


def _plain_score(c: NDArray, p: AffinityParams) -> NDArray[np.float64]:
    return np.where(c <= p.epsilon, np.exp(-(c**2) / (2.0 * p.sigma**2)), 0.0)


def pairwise_consistency(va: NDArray, vb: NDArray, params: AffinityParams) -> NDArray[np.float64]:
    """s_a for associations whose object differences are ``va = a_i - a_j``, ``vb = b_i - b_j``.

    Args:
        va: (..., 3) difference vectors in submap a's (gravity-aligned) frame.
        vb: (..., 3) difference vectors in submap b's frame.
        params: sigma, epsilon, mindist, gravity, gravity_uncertainty_deg are used.

    Returns: (...,) scores in [0, 1]; 0 when a length is below ``mindist`` or a gate fails.
    """
    va, vb = np.asarray(va, dtype=np.float64), np.asarray(vb, dtype=np.float64)
    ha, hb = np.hypot(va[..., 0], va[..., 1]), np.hypot(vb[..., 0], vb[..., 1])
    return _component_score(ha, va[..., 2], hb, vb[..., 2], params)


def _component_score(ha: NDArray, za: NDArray, hb: NDArray, zb: NDArray, p: AffinityParams) -> NDArray[np.float64]:
    """s_a from lateral lengths ``ha``, ``hb`` and signed vertical differences ``za``, ``zb``."""
    l1, l2 = np.hypot(ha, za), np.hypot(hb, zb)
    if p.gravity:
        s = _residual_score(np.abs(ha - hb), np.abs(za - zb), 0.5 * (ha + hb), 0.5 * (np.abs(za) + np.abs(zb)), p)
    else:
        s = _plain_score(np.abs(l1 - l2), p)
    return np.where((l1 < p.mindist) | (l2 < p.mindist), 0.0, s)


def min_max_ratio(x: NDArray, y: NDArray) -> NDArray[np.float64]:
    """min/max of every pair (n_a, n_b); 1 when both are 0."""
    x, y = np.abs(x)[:, None], np.abs(y)[None, :]
    hi, lo = np.maximum(x, y), np.minimum(x, y)
    return np.divide(lo, hi, out=np.ones(np.broadcast_shapes(x.shape, y.shape)), where=hi > 0)


def shape_scores(a: Submap, b: Submap) -> NDArray[np.float64]:
    """(n_a, n_b) geometric mean of volume, linearity, planarity, scattering ratios."""
    logs = np.log(np.maximum(min_max_ratio(a.volumes, b.volumes), 1e-300))
    for k in range(3):
        logs += np.log(np.maximum(min_max_ratio(a.shape[:, k], b.shape[:, k]), 1e-300))
    return np.exp(logs / 4.0)


def cosine_matrix(a: Submap, b: Submap) -> NDArray[np.float64]:
    """(n_a, n_b) cosine of the semantic descriptors.

    Uses einsum rather than BLAS: at this size (40 x 768) a multithreaded BLAS call is
    dominated by thread wake-ups, which is slow and erratic on a busy machine.
    """
    da = np.asarray(a.descriptors, dtype=np.float32)
    db = np.asarray(b.descriptors, dtype=np.float32)
    na = np.sqrt(np.einsum("ij,ij->i", da, da))
    nb = np.sqrt(np.einsum("ij,ij->i", db, db))
    return np.einsum("id,jd->ij", da, db).astype(np.float64) / np.outer(na, nb)


def semantic_scores(a: Submap, b: Submap, cos_min: float, cos_max: float) -> NDArray[np.float64]:
    """(n_a, n_b) cosine rescaled to [0, 1] between ``cos_min`` and ``cos_max``."""
    return np.clip((cosine_matrix(a, b) - cos_min) / (cos_max - cos_min), 0.0, 1.0)


def object_scores(a: Submap, b: Submap, params: AffinityParams) -> NDArray[np.float64]:
    """s_o for every object pair (n_a, n_b): geometric mean of the enabled terms (1 if none)."""
    terms = []
    if params.use_shape:
        terms.append(shape_scores(a, b))
    if params.use_semantics:
        terms.append(semantic_scores(a, b, params.cos_min, params.cos_max))
    if not terms:
        return np.ones((len(a), len(b)))
    return np.prod(terms, axis=0) ** (1.0 / len(terms))


def _fuse(s_a: NDArray, so_p: NDArray, so_q: NDArray, fusion: Fusion, with_objects: bool) -> NDArray:
    """Edge weights from s_a and the two object scores (s_a alone when s_o is off)."""
    if not with_objects:
        return s_a
    return _FUSIONS[fusion](s_a, so_p, so_q)


_FUSIONS = {
    "geometric": lambda s, p, q: np.cbrt(s * p * q),
    "arithmetic": lambda s, p, q: (s + p + q) / 3.0,
    "product": lambda s, p, q: s * p * q,
}


def consistency_edges(
    centers_a: NDArray, centers_b: NDArray, ia: NDArray[np.int64], ib: NDArray[np.int64], params: AffinityParams
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Scored edges (p < q) among associations ``(ia[p], ib[p])``.

    Instead of touching all P^2 association pairs, object pairs of a and of b are joined
    on their length (lateral with gravity, 3D without) through a sorted interval search:
    only pairs passing the length gate are ever formed, then scored exactly. Associations
    sharing an object never connect (object pairs are of distinct objects).

    Returns: (rows, cols, s_a) with rows < cols and s_a > 0.
    """
    ca, cb = np.asarray(centers_a, dtype=np.float64), np.asarray(centers_b, dtype=np.float64)
    nb = len(cb)
    lookup = np.full(len(ca) * nb, -1, dtype=np.int64)
    lookup[ia * nb + ib] = np.arange(len(ia))
    gate = params.epsilon * (_XY if params.gravity else 1.0) + _widening_bounds(ca, cb, params)[0]
    A, B = _ObjectPairs(ca, params), _ObjectPairs(cb, params)
    B.sort()
    lo = np.searchsorted(B.key, A.key - gate, side="left")
    hi = np.searchsorted(B.key, A.key + gate, side="right")
    counts = hi - lo
    pa = np.repeat(np.arange(len(A.key)), counts)
    pb = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + np.repeat(lo, counts)
    rows, cols, scores = [], [], []
    # the b pair (j, l) pairs with the a pair (i, k) in both orientations: (i-j, k-l) and (i-l, k-j)
    for bi, bk, sign in ((B.i, B.k, 1.0), (B.k, B.i, -1.0)):
        p, q = lookup[A.i[pa] * nb + bi[pb]], lookup[A.k[pa] * nb + bk[pb]]
        ok = (p >= 0) & (q >= 0)
        sa, sb = pa[ok], pb[ok]
        s = _component_score(A.h[sa], A.z[sa], B.h[sb], sign * B.z[sb], params)
        good = s > 0
        rows.append(p[ok][good])
        cols.append(q[ok][good])
        scores.append(s[good])
    p, q = np.concatenate(rows), np.concatenate(cols)
    return np.minimum(p, q), np.maximum(p, q), np.concatenate(scores)


class _ObjectPairs:
    """Pairs i < k of one submap's objects: lateral length ``h``, signed ``z`` = z_i - z_k, join key."""

    def __init__(self, c: NDArray, p: AffinityParams) -> None:
        i, k = np.triu_indices(len(c), 1)
        dx, dy, dz = (c[i, d] - c[k, d] for d in range(3))
        h = np.hypot(dx, dy)
        far = np.hypot(h, dz) >= p.mindist
        self.i, self.k, self.h, self.z = i[far], k[far], h[far], dz[far]
        self.key = self.h if p.gravity else np.hypot(self.h, self.z)

    def sort(self) -> None:
        """Sort by the join key."""
        o = np.argsort(self.key, kind="stable")
        self.i, self.k, self.h, self.z, self.key = self.i[o], self.k[o], self.h[o], self.z[o], self.key[o]


def _widening_bounds(ca: NDArray, cb: NDArray, p: AffinityParams) -> tuple[float, float]:
    """Upper bounds of the lateral and vertical widening, so the early gates never cut a valid pair."""
    if p.gravity_uncertainty_deg <= 0:
        return 0.0, 0.0
    th = np.deg2rad(p.gravity_uncertainty_deg)
    span_xy = max(np.ptp(ca[:, 0]) + np.ptp(ca[:, 1]), np.ptp(cb[:, 0]) + np.ptp(cb[:, 1]))
    span_z = max(np.ptp(ca[:, 2]), np.ptp(cb[:, 2]))
    return float(span_xy * (1 - np.cos(th))) + 1e-6, float(span_z * np.sin(th)) + 1e-6


def csr_from_entries(rows: NDArray, cols: NDArray, vals: NDArray, n: int) -> sp.csr_matrix:
    """(n, n) CSR from unique (row, col) entries by a stable counting sort on rows.

    Avoids scipy's COO conversion, which sorts every row's column indices; the matrix is
    only used for mat-vecs and row look-ups, so column order within a row is left as is.
    Rows are sorted as 16-bit keys when possible (NumPy then uses an O(n) radix sort).
    """
    key = rows.astype(np.uint16) if n <= np.iinfo(np.uint16).max else rows
    order = np.argsort(key, kind="stable")
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=indptr[1:])
    index_dtype = np.int32 if n < np.iinfo(np.int32).max else np.int64
    return sp.csr_matrix(
        (vals[order].astype(np.float64), cols[order].astype(index_dtype), indptr.astype(index_dtype)), shape=(n, n)
    )


def build_affinity(
    centers_a: NDArray,
    centers_b: NDArray,
    assoc: NDArray[np.int64],
    s_o: NDArray[np.float64] | None,
    params: AffinityParams,
) -> sp.csr_matrix:
    """The (P, P) sparse affinity over associations ``assoc`` ((P, 2) indices into a, b).

    Args:
        s_o: (P,) object score per association, or None when no object score is used.

    Returns: symmetric CSR with unit diagonal; entries <= ``min_affinity`` dropped.
    """
    assoc = np.asarray(assoc, dtype=np.int64).reshape(-1, 2)
    P = len(assoc)
    if P and ((assoc < 0).any() or assoc[:, 0].max() >= len(centers_a) or assoc[:, 1].max() >= len(centers_b)):
        raise ConfigError("assoc: indices out of range of the submaps' segments")
    if P and len(np.unique(assoc[:, 0] * len(centers_b) + assoc[:, 1])) != P:
        raise ConfigError("assoc: duplicate associations")
    rows, cols, s_a = consistency_edges(centers_a, centers_b, assoc[:, 0], assoc[:, 1], params)
    so = np.ones(P) if s_o is None else np.asarray(s_o, dtype=np.float64)
    w = _fuse(s_a, so[rows], so[cols], params.fusion, s_o is not None)
    good = w > params.min_affinity
    r, c, w = rows[good], cols[good], w[good]
    diag = np.arange(P)
    M = csr_from_entries(
        np.concatenate([r, c, diag]), np.concatenate([c, r, diag]), np.concatenate([w, w, np.ones(P)]), P
    )
    log.debug("affinity: %d associations, %d edges", P, len(w))
    return M
