"""Rigid-body geometry in pure numpy: SE(3) helpers, yaw/gravity alignment, Arun, PCA.

Conventions: ``T_a_b`` is a 4x4 float64 matrix mapping points in frame b into frame a.
Angles are radians. Body frame FLU, camera optical frame RDF.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]

#: Rotation body (FLU) -> camera optical (RDF): columns are the camera axes in FLU.
R_FLU_RDF: F64 = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def make_T(R: ArrayLike | None = None, t: ArrayLike | None = None) -> F64:
    """4x4 transform from a 3x3 rotation and a 3-vector translation."""
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = np.asarray(R, dtype=np.float64)
    if t is not None:
        T[:3, 3] = np.asarray(t, dtype=np.float64)
    return T


def inv_T(T: ArrayLike) -> F64:
    """Inverse of a rigid transform (exact, no general matrix inverse)."""
    T = np.asarray(T, dtype=np.float64)
    R, t = T[:3, :3], T[:3, 3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ t
    return out


def transform_points(T: ArrayLike, pts: ArrayLike) -> F64:
    """Apply ``T`` (4x4) to points (N, 3); returns (N, 3)."""
    T = np.asarray(T, dtype=np.float64)
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 3)
    return pts @ T[:3, :3].T + T[:3, 3]


def rot_x(a: float) -> F64:
    """Rotation about x by ``a`` radians."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> F64:
    """Rotation about y by ``a`` radians."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def rot_z(a: float) -> F64:
    """Rotation about z by ``a`` radians."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def rpy_to_R(roll: float, pitch: float, yaw: float) -> F64:
    """ZYX Euler (yaw, then pitch, then roll) to a rotation matrix."""
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


def R_to_rpy(R: ArrayLike) -> tuple[float, float, float]:
    """Rotation matrix to ZYX Euler angles (roll, pitch, yaw)."""
    R = np.asarray(R, dtype=np.float64)
    pitch = float(np.arcsin(np.clip(-R[2, 0], -1.0, 1.0)))
    roll = float(np.arctan2(R[2, 1], R[2, 2]))
    yaw = float(np.arctan2(R[1, 0], R[0, 0]))
    return roll, pitch, yaw


def yaw_of(T_or_R: ArrayLike) -> float:
    """ZYX yaw of a pose or rotation."""
    M = np.asarray(T_or_R, dtype=np.float64)
    return float(np.arctan2(M[1, 0], M[0, 0]))


def wrap_angle(a: ArrayLike) -> NDArray[np.float64] | float:
    """Wrap angles to (-pi, pi]."""
    out = (np.asarray(a, dtype=np.float64) + np.pi) % (2 * np.pi) - np.pi
    out = np.where(out <= -np.pi, out + 2 * np.pi, out)
    return float(out) if out.ndim == 0 else out


def gravity_aligned(T: ArrayLike) -> F64:
    """Same translation, rotation reduced to its ZYX yaw (roll = pitch = 0)."""
    T = np.asarray(T, dtype=np.float64)
    return make_T(rot_z(yaw_of(T)), T[:3, 3])


def pose_4dof(x: float, y: float, z: float, yaw: float) -> F64:
    """A 4-DoF pose (translation + yaw)."""
    return make_T(rot_z(yaw), [x, y, z])


def rotation_angle(R: ArrayLike) -> float:
    """Angle (radians, in [0, pi]) of a rotation matrix, accurate over the whole range.

    ``atan2(sin, cos)`` with ``sin = |vee(R - R^T)| / 2`` and ``cos = (tr R - 1) / 2``:
    ``arccos`` of the cosine alone loses half the digits near 0 (a floor near 1.5e-8 rad), so
    two machines whose SVDs differ in the last bit would report different small errors.
    """
    R = np.asarray(R, dtype=np.float64)
    axial = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(np.arctan2(0.5 * np.linalg.norm(axial), 0.5 * (np.trace(R) - 1.0)))


def pose_error(T_est: ArrayLike, T_true: ArrayLike) -> tuple[float, float]:
    """(rotation error rad, translation error m) of ``T_est`` against ``T_true``."""
    E = inv_T(T_true) @ np.asarray(T_est, dtype=np.float64)
    return rotation_angle(E[:3, :3]), float(np.linalg.norm(np.asarray(T_est)[:3, 3] - np.asarray(T_true)[:3, 3]))


def arun(src: ArrayLike, dst: ArrayLike, weights: ArrayLike | None = None) -> F64:
    """Least-squares rigid transform ``T`` with ``dst ~ T @ src`` (Arun/Kabsch SVD).

    Args:
        src: (N, 3) points, N >= 3 and not collinear.
        dst: (N, 3) their corresponding points.
        weights: optional (N,) non-negative weights.

    Returns: 4x4 transform; reflections are fixed (det R = +1).
    """
    src = np.asarray(src, dtype=np.float64).reshape(-1, 3)
    dst = np.asarray(dst, dtype=np.float64).reshape(-1, 3)
    w = np.ones(len(src)) if weights is None else np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    cs, cd = w @ src, w @ dst
    H = (src - cs).T @ ((dst - cd) * w[:, None])
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    R = Vt.T @ D @ U.T
    return make_T(R, cd - R @ cs)


def arun_4dof(src: ArrayLike, dst: ArrayLike, weights: ArrayLike | None = None) -> F64:
    """Least-squares yaw + translation ``T`` with ``dst ~ T @ src`` (gravity-aligned frames).

    Closed form: yaw from the 2D cross-covariance, z from the mean height difference.
    """
    src = np.asarray(src, dtype=np.float64).reshape(-1, 3)
    dst = np.asarray(dst, dtype=np.float64).reshape(-1, 3)
    w = np.ones(len(src)) if weights is None else np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    cs, cd = w @ src, w @ dst
    a, b = (src - cs)[:, :2], (dst - cd)[:, :2]
    s_cos = np.sum(w * (a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
    s_sin = np.sum(w * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    yaw = float(np.arctan2(s_sin, s_cos))
    R = rot_z(yaw)
    return make_T(R, cd - R @ cs)


def pca_shape_features(points: ArrayLike) -> tuple[float, float, float]:
    """(linearity, planarity, scattering) from PCA of the point covariance.

    Eigenvalues are normalised to sum to 1 and sorted e1 >= e2 >= e3;
    linearity = (e1-e2)/e1, planarity = (e2-e3)/e1, scattering = e3/e1.
    Degenerate inputs (fewer than 3 points, zero spread) give (0, 0, 0).
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) < 3:
        return 0.0, 0.0, 0.0
    ev = np.sort(np.linalg.eigvalsh(np.cov(pts.T)))[::-1]
    ev = np.clip(ev, 0.0, None)
    total = ev.sum()
    if total <= 0 or ev[0] <= 0:
        return 0.0, 0.0, 0.0
    e1, e2, e3 = ev / total
    return float((e1 - e2) / e1), float((e2 - e3) / e1), float(e3 / e1)


def voxel_downsample(points: ArrayLike, voxel: float) -> F64:
    """One point per occupied voxel (the mean of its points), in a deterministic order."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) == 0:
        return pts
    keys = np.floor(pts / voxel).astype(np.int64)
    _, inv, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    out = np.zeros((len(counts), 3))
    np.add.at(out, inv, pts)
    return out / counts[:, None]


def voxel_keys(points: ArrayLike, voxel: float) -> NDArray[np.int64]:
    """Unique integer voxel keys (M, 3) of points at resolution ``voxel``."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) == 0:
        return np.zeros((0, 3), dtype=np.int64)
    return np.unique(np.floor(pts / voxel).astype(np.int64), axis=0)
