"""3-point RANSAC on all-to-all centroid correspondences (the paper's RANSAC baselines).

Every pair (a_i, b_j) is a putative correspondence. A hypothesis draws 3 correspondences,
must pass the edge-length check (each of the 3 edges agrees within ``edge_ratio``, as in
Open3D's correspondence checker), gets a closed-form Kabsch fit, and is scored by how many
putative correspondences land within ``max_corr_dist_m`` (ties: lower inlier RMSE). The
best hypothesis is refined on its one-to-one inliers. Vectorised over hypothesis batches.

``iterations`` counts drawn hypotheses, as in the reference. Most fail the first edge check,
so the sampler enumerates the compatible edge pairs once per submap pair and draws only the
hypotheses that pass it, in the same distribution (see ``_sample``): the cost follows the
hypotheses that are fitted, not the ones drawn.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydantic import Field
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from roman_sim.align.registration import estimate_transform, kabsch_batch
from roman_sim.core.config import StrictModel
from roman_sim.core.geometry import transform_points
from roman_sim.core.seeding import child_rng

log = logging.getLogger(__name__)


class RansacParams(StrictModel):
    """RANSAC settings (reference values)."""

    iterations: int = Field(100_000, ge=1, le=100_000_000, description="hypotheses drawn")
    max_corr_dist_m: float = Field(0.5, gt=0, description="inlier distance")
    edge_ratio: float = Field(0.95, gt=0, le=1, description="edge-length similarity check")
    batch_size: int = Field(100_000, ge=1000, description="hypotheses per vectorised batch")
    seed: int = Field(0, ge=0, description="seed of the sampler (via child_rng)")


@dataclass
class RansacOutcome:
    """Best hypothesis: transform (or None), one-to-one inliers (k, 2) and counts."""

    T_a_b: NDArray[np.float64] | None
    associations: NDArray[np.int64]
    n_inliers: int
    n_checked: int
    reason: str | None = None


def _ratio_ok(la: NDArray, lb: NDArray, ratio: float) -> NDArray[np.bool_]:
    """Edge-length check of Open3D's correspondence checker (a zero length fails)."""
    return (la > 0) & (la >= ratio * lb) & (lb >= ratio * la)


def compatible_edges(Da: NDArray, Db: NDArray, ratio: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every (ordered a-edge, ordered b-edge) whose lengths pass the edge check, as flat indices.

    An edge ``(i, j)`` of a is ``i * n_a + j`` (likewise for b). Lengths are joined through a
    sorted search on b's lengths, so only pairs near the ratio band are formed, then checked
    exactly as a drawn triple would be.
    """
    la, lb = np.asarray(Da, np.float64).ravel(), np.asarray(Db, np.float64).ravel()
    order = np.argsort(lb, kind="stable")
    lbs = lb[order]
    slack = 1e-9 * (1.0 + float(la.max(initial=0.0)))  # the band is widened, the exact check decides
    lo = np.searchsorted(lbs, ratio * la - slack, side="left")
    hi = np.searchsorted(lbs, la / ratio + slack, side="right")
    counts = np.where(la > 0, hi - lo, 0)
    ea = np.repeat(np.arange(len(la)), counts)
    eb = order[np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + np.repeat(lo, counts)]
    ok = _ratio_ok(la[ea], lb[eb], ratio)
    return ea[ok].astype(np.int64), eb[ok].astype(np.int64)


def _sample(
    rng: np.random.Generator,
    na: int,
    nb: int,
    k: int,
    Da: NDArray,
    Db: NDArray,
    ratio: float,
    edges: tuple[NDArray[np.int64], NDArray[np.int64]],
) -> tuple[NDArray, NDArray]:
    """``k`` uniform triples of correspondences; (ia, ib) (m, 3) of those passing the edge checks.

    Equivalent in distribution to drawing ``k`` triples and checking all three edges, but
    the draws that fail the first edge are never made: of ``k`` uniform draws,
    Binomial(k, C / (n_a^2 n_b^2)) pass the first edge, each a uniform one of the ``C``
    compatible edge pairs ``edges``; only those get a third correspondence drawn and checked.
    """
    ea, eb = edges
    n = int(rng.binomial(k, len(ea) / float(na * na * nb * nb))) if len(ea) else 0
    pick = rng.integers(0, len(ea), n) if n else np.zeros(0, np.int64)
    ia = np.stack([ea[pick] // na, ea[pick] % na, rng.integers(0, na, n)], 1)
    ib = np.stack([eb[pick] // nb, eb[pick] % nb, rng.integers(0, nb, n)], 1)
    fa, fb = np.asarray(Da).ravel(), np.asarray(Db).ravel()
    ok = np.ones(n, dtype=bool)
    for s, t in ((1, 2), (0, 2)):
        ok &= _ratio_ok(fa[ia[:, s] * na + ia[:, t]], fb[ib[:, s] * nb + ib[:, t]], ratio)
    return ia[ok].astype(np.int64), ib[ok].astype(np.int64)


def _score(Ts: NDArray, ca: NDArray, cb: NDArray, thr: float) -> tuple[NDArray, NDArray]:
    """Inlier counts and inlier RMSE of each (K, 4, 4) hypothesis over all a-b pairs."""
    moved = np.einsum("kij,nj->kni", Ts[:, :3, :3], cb) + Ts[:, None, :3, 3]
    d2 = np.sum((moved[:, None, :, :] - ca[None, :, None, :]) ** 2, axis=-1)
    inl = d2 <= thr * thr
    cnt = inl.sum(axis=(1, 2))
    rmse = np.sqrt(np.where(inl, d2, 0.0).sum(axis=(1, 2)) / np.maximum(cnt, 1))
    return cnt, rmse


def one_to_one(ca: NDArray, cb_in_a: NDArray, thr: float) -> NDArray[np.int64]:
    """Hungarian one-to-one pairs (a_idx, b_idx) closer than ``thr``."""
    D = cdist(ca, cb_in_a)
    r, c = linear_sum_assignment(np.where(D <= thr, D, 1e6))
    keep = D[r, c] <= thr
    return np.stack([r[keep], c[keep]], 1).astype(np.int64)


def ransac_align(centers_a: NDArray, centers_b: NDArray, params: RansacParams | None = None) -> RansacOutcome:
    """Best 3-point RANSAC transform ``T_a_b`` (b into a) on all-to-all correspondences."""
    p = params or RansacParams()
    ca, cb = np.asarray(centers_a, dtype=np.float64), np.asarray(centers_b, dtype=np.float64)
    Da, Db = cdist(ca, ca), cdist(cb, cb)
    rng = child_rng(p.seed, "ransac")
    edges = compatible_edges(Da, Db, p.edge_ratio)
    best = (-1, np.inf, None)
    checked, left = 0, p.iterations
    while left > 0:
        k = min(left, p.batch_size)
        left -= k
        ia, ib = _sample(rng, len(ca), len(cb), k, Da, Db, p.edge_ratio, edges)
        for s in range(0, len(ia), 2000):
            Ts = kabsch_batch(cb[ib[s : s + 2000]], ca[ia[s : s + 2000]])
            cnt, rmse = _score(Ts, ca, cb, p.max_corr_dist_m)
            order = np.lexsort((rmse, -cnt))[0]
            if (cnt[order], -rmse[order]) > (best[0], -best[1]):
                best = (int(cnt[order]), float(rmse[order]), Ts[order])
            checked += len(Ts)
    if best[2] is None:
        return RansacOutcome(None, np.zeros((0, 2), np.int64), 0, checked, "no hypothesis passed the edge check")
    assoc = one_to_one(ca, transform_points(best[2], cb), p.max_corr_dist_m)
    T, why = estimate_transform(cb[assoc[:, 1]], ca[assoc[:, 0]]) if len(assoc) >= 3 else (best[2], None)
    if T is None:
        T = best[2]
    log.debug("ransac: %d hypotheses checked, best %d inliers (%s)", checked, best[0], why)
    return RansacOutcome(T, assoc, best[0], checked)
