"""Ground-truth ambiguity of places: how well a *wrong* rigid transform explains a place.

Definition (one place). Let P be the objects whose origin lies in the disc of radius
``radius_m`` (a submap) around ``center_xy`` and Q the objects within
``region_factor * radius_m`` of it. Each object is described by its family and its size
(largest oriented-box extent). Hypotheses are 2D rigid transforms (yaw + translation)
that map an anchor pair (i, j) of P onto a pair (k, l) of Q with the same families, sizes
within ``size_tol`` (relative) and pair lengths within ``2 * inlier_m``. A hypothesis is
*wrong* when it rotates by more than ``min_wrong_yaw_deg`` or moves the disc centre by more
than ``min_wrong_shift_m``. An object of P is an inlier of a hypothesis when, mapped by it,
it lands within ``inlier_m`` of a Q object of the same family in the joint space
(x, y, ``inlier_m * log(size) / log(1 + size_tol)``), so a size mismatch counts like
distance. The place's ambiguity is::

    max(0, best_wrong_inliers - 2) / (|P| - 2)        in [0, 1]

(the two anchor objects always match, so they are not counted); places with fewer than
three objects score 0. A perfect lattice of identical objects scores ~1, a random forest
of varied trees close to 0. ``ambiguity_index`` averages it over ``n_places`` random discs.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from roman_sim.core.errors import WorldError
from roman_sim.core.seeding import child_rng
from roman_sim.world.truth import WorldTruth

MAX_ANCHOR_PAIRS = 40
MAX_HYPOTHESES = 1500
FAMILY_SEP = 1e6  # separates families in the KD-tree feature space


def _features(truth: WorldTruth, inlier_m: float, size_tol: float) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """(N, 4) features [x, y, family offset, scaled log size] and (N,) family codes."""
    fams = {f: i for i, f in enumerate(truth.families())}
    code = np.array([fams[o.family] for o in truth.objects], dtype=np.int64)
    xy = np.stack([o.T_world_obj[:2, 3] for o in truth.objects])
    size = np.array([max(float(o.extents[0]), 1e-3) for o in truth.objects])
    k = inlier_m / np.log1p(size_tol)
    return np.column_stack([xy, code * FAMILY_SEP, k * np.log(size)]), code


def _pairs(idx: NDArray[np.int64], ordered: bool) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    a, b = np.meshgrid(idx, idx, indexing="ij")
    keep = a != b if ordered else a < b
    return a[keep], b[keep]


def _hypotheses(
    F: NDArray[np.float64],
    code: NDArray[np.int64],
    P: NDArray[np.int64],
    Q: NDArray[np.int64],
    inlier_m: float,
    rng: np.random.Generator,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Yaws (H,) and translations (H, 2) mapping anchor pairs of P onto matching pairs of Q."""
    ai, aj = _pairs(P, ordered=False)
    if len(ai) > MAX_ANCHOR_PAIRS:
        sel = rng.choice(len(ai), MAX_ANCHOR_PAIRS, replace=False)
        ai, aj = ai[sel], aj[sel]
    qk, ql = _pairs(Q, ordered=True)
    vp = F[aj, :2] - F[ai, :2]
    vq = F[ql, :2] - F[qk, :2]
    dp, dq = np.linalg.norm(vp, axis=1), np.linalg.norm(vq, axis=1)
    size_ok = lambda a, b: np.abs(F[a, 3][:, None] - F[b, 3][None]) <= inlier_m  # noqa: E731
    match = (code[ai][:, None] == code[qk][None]) & (code[aj][:, None] == code[ql][None])
    match &= np.abs(dp[:, None] - dq[None]) <= 2 * inlier_m
    match &= size_ok(ai, qk) & size_ok(aj, ql)
    m_a, m_q = np.nonzero(match)
    if len(m_a) > MAX_HYPOTHESES:
        sel = rng.choice(len(m_a), MAX_HYPOTHESES, replace=False)
        m_a, m_q = m_a[sel], m_q[sel]
    yaw = np.arctan2(vq[m_q, 1], vq[m_q, 0]) - np.arctan2(vp[m_a, 1], vp[m_a, 0])
    c, s = np.cos(yaw), np.sin(yaw)
    p = F[ai[m_a], :2]
    rp = np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]], 1)
    return yaw, F[qk[m_q], :2] - rp


def place_ambiguity(
    truth: WorldTruth,
    center_xy: ArrayLike,
    radius_m: float = 15.0,
    region_factor: float = 2.0,
    inlier_m: float = 0.5,
    size_tol: float = 0.25,
    min_wrong_shift_m: float = 2.0,
    min_wrong_yaw_deg: float = 10.0,
    seed: int = 0,
) -> float:
    """Ambiguity in [0, 1] of the disc around ``center_xy`` (see the module docstring)."""
    if radius_m <= 0 or region_factor < 1 or inlier_m <= 0 or size_tol <= 0:
        raise WorldError("place_ambiguity: need radius_m > 0, region_factor >= 1, inlier_m > 0, size_tol > 0")
    if len(truth.objects) < 3:
        return 0.0
    c = np.asarray(center_xy, dtype=np.float64).reshape(2)
    F, code = _features(truth, inlier_m, size_tol)
    dist = np.linalg.norm(F[:, :2] - c, axis=1)
    P, Q = np.flatnonzero(dist <= radius_m), np.flatnonzero(dist <= region_factor * radius_m)
    if len(P) < 3:
        return 0.0
    yaw, t = _hypotheses(F, code, P, Q, inlier_m, child_rng(seed, "ambiguity", "hypotheses"))
    cos, sin = np.cos(yaw), np.sin(yaw)
    shift = np.stack([cos * c[0] - sin * c[1], sin * c[0] + cos * c[1]], 1) + t - c
    yaw_err = np.abs(np.angle(np.exp(1j * yaw)))
    wrong = (yaw_err > np.radians(min_wrong_yaw_deg)) | (np.linalg.norm(shift, axis=1) > min_wrong_shift_m)
    if not np.any(wrong):
        return 0.0
    cos, sin, t = cos[wrong], sin[wrong], t[wrong]
    p = F[P]
    mx = cos[:, None] * p[None, :, 0] - sin[:, None] * p[None, :, 1] + t[:, None, 0]
    my = sin[:, None] * p[None, :, 0] + cos[:, None] * p[None, :, 1] + t[:, None, 1]
    mapped = np.stack([mx, my, np.broadcast_to(p[:, 2], mx.shape), np.broadcast_to(p[:, 3], mx.shape)], -1)
    d, _ = cKDTree(F[Q]).query(mapped.reshape(-1, 4), distance_upper_bound=inlier_m)
    inliers = np.isfinite(d).reshape(mx.shape).sum(1).max()
    return float(max(0, inliers - 2) / (len(P) - 2))


def ambiguity_index(
    truth: WorldTruth, n_places: int = 50, radius_m: float = 15.0, seed: int = 0, **kwargs: float
) -> float:
    """Mean ``place_ambiguity`` over ``n_places`` random disc centres inside the extent."""
    if n_places < 1:
        raise WorldError(f"ambiguity_index: n_places must be >= 1, got {n_places}")
    t = truth.terrain
    half = np.array([max(t.size_x / 2 - radius_m, 0.0), max(t.size_y / 2 - radius_m, 0.0)])
    centres = child_rng(seed, "ambiguity", "places").uniform(-half, half, (n_places, 2))
    return float(np.mean([place_ambiguity(truth, c, radius_m, seed=seed, **kwargs) for c in centres]))
