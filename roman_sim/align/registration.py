"""Rigid registration of associated object centres: Arun/Kabsch (6-DoF) or yaw + translation.

Thin, checked wrappers over ``roman_sim.core.geometry.arun`` / ``arun_4dof``: degenerate point
sets (fewer than 3 points, coincident or collinear centres) and implausible tilts give a
reason string instead of a transform, never a numpy error.
"""

from __future__ import annotations

import logging
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.geometry import R_to_rpy, arun, arun_4dof

log = logging.getLogger(__name__)

Dof = Literal[4, 6]

#: Relative size of the second singular value below which centres count as collinear.
COLLINEAR_TOL = 1e-3


def degeneracy(points: NDArray, dof: Dof = 6) -> str | None:
    """Why ``points`` (N, 3) cannot fix a rigid transform, or None if they can."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) < 3:
        return f"fewer than 3 points ({len(pts)})"
    if not np.all(np.isfinite(pts)):
        return "non-finite centres"
    centred = pts - pts.mean(axis=0)
    use = centred[:, :2] if dof == 4 else centred
    sv = np.linalg.svd(use, compute_uv=False)
    if sv[0] <= 1e-9:
        return "coincident centres"
    if dof == 6 and sv[1] <= COLLINEAR_TOL * sv[0]:
        return "collinear centres"
    return None


def estimate_transform(
    src: NDArray, dst: NDArray, weights: NDArray | None = None, dof: Dof = 6
) -> tuple[NDArray[np.float64] | None, str | None]:
    """``T`` with ``dst ~ T @ src`` from corresponding centres.

    Args:
        src: (N, 3) points.
        dst: (N, 3) their corresponding points.
        weights: optional (N,) non-negative weights (all-zero weights fall back to uniform).
        dof: 6 (Arun/Kabsch) or 4 (yaw + translation, for gravity-aligned frames).

    Returns: (T, None) or (None, reason).
    """
    src = np.asarray(src, dtype=np.float64).reshape(-1, 3)
    dst = np.asarray(dst, dtype=np.float64).reshape(-1, 3)
    if len(src) != len(dst):
        return None, f"src and dst sizes differ ({len(src)} vs {len(dst)})"
    for name, pts in (("src", src), ("dst", dst)):
        why = degeneracy(pts, dof)
        if why:
            return None, f"{name}: {why}"
    w = None
    if weights is not None:
        w = np.asarray(weights, dtype=np.float64).reshape(-1)
        if len(w) != len(src) or not np.all(np.isfinite(w)) or (w < 0).any():
            return None, "weights must be finite, non-negative, one per point"
        if w.sum() <= 0:
            w = None
    fit = arun_4dof if dof == 4 else arun
    return fit(src, dst, w), None


def tilt_ok(T: NDArray, max_roll_pitch_deg: float) -> bool:
    """Whether |roll| and |pitch| of ``T`` are within ``max_roll_pitch_deg``."""
    roll, pitch, _ = R_to_rpy(np.asarray(T)[:3, :3])
    lim = np.deg2rad(max_roll_pitch_deg)
    return bool(abs(roll) <= lim and abs(pitch) <= lim)


def kabsch_batch(src: NDArray, dst: NDArray) -> NDArray[np.float64]:
    """Batched unweighted Kabsch: (K, N, 3) src and dst -> (K, 4, 4) with ``dst ~ T src``."""
    cs, cd = src.mean(axis=1, keepdims=True), dst.mean(axis=1, keepdims=True)
    H = np.einsum("kni,knj->kij", src - cs, dst - cd)
    U, _, Vt = np.linalg.svd(H)
    det = np.sign(np.linalg.det(np.einsum("kji,klj->kil", Vt, U)))
    det[det == 0] = 1.0
    D = np.zeros((len(src), 3, 3))
    D[:, 0, 0] = D[:, 1, 1] = 1.0
    D[:, 2, 2] = det
    R = np.einsum("kji,kjl,klm->kim", Vt, D, np.swapaxes(U, 1, 2))
    T = np.zeros((len(src), 4, 4))
    T[:, :3, :3] = R
    T[:, :3, 3] = cd[:, 0] - np.einsum("kij,kj->ki", R, cs[:, 0])
    T[:, 3, 3] = 1.0
    return T
