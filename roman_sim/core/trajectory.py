"""``Trajectory``: timestamps + poses, validated once, used everywhere (pose graph, ATE, TUM).

A trajectory is ``t`` (N,) float64 seconds, non-decreasing and finite, and ``T`` (N, 4, 4)
float64 poses ``T_frame_body`` with finite entries and a last row ``[0, 0, 0, 1]``. Two
trajectories are associated by nearest timestamps within a tolerance (each reference pose
used once), as evo and the TUM tools do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roman_sim.core.errors import EvaluationError

F64 = NDArray[np.float64]

#: Default timestamp association tolerance (s).
MAX_DIFF_S = 0.01


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Timestamps (N,) and poses (N, 4, 4) of one body in one frame.

    Raises:
        EvaluationError: shapes disagree, values are not finite, or time goes backwards.
    """

    t: F64
    T: F64

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=np.float64).reshape(-1)
        T = np.asarray(self.T, dtype=np.float64)
        if T.ndim != 3 or T.shape != (len(t), 4, 4):
            raise EvaluationError(
                f"trajectory: expected poses of shape ({len(t)}, 4, 4) for {len(t)} timestamps, got {T.shape}"
            )
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(T))):
            raise EvaluationError("trajectory: timestamps and poses must be finite (NaN or inf found)")
        if len(t) > 1 and np.any(np.diff(t) < 0):
            k = int(np.flatnonzero(np.diff(t) < 0)[0]) + 1
            raise EvaluationError(f"trajectory: time goes backwards at pose {k} ({t[k - 1]} -> {t[k]} s)")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "T", T)

    @classmethod
    def empty(cls) -> "Trajectory":
        """A trajectory with no poses."""
        return cls(np.zeros(0), np.zeros((0, 4, 4)))

    def __len__(self) -> int:
        return int(len(self.t))

    @property
    def positions(self) -> F64:
        """(N, 3) positions."""
        return self.T[:, :3, 3]

    @property
    def length_m(self) -> float:
        """Path length (sum of position increments)."""
        if len(self) < 2:
            return 0.0
        return float(np.linalg.norm(np.diff(self.positions, axis=0), axis=1).sum())

    def transformed(self, A: ArrayLike) -> "Trajectory":
        """``A @ T`` for every pose (the same body seen from another frame)."""
        A = np.asarray(A, dtype=np.float64)
        return Trajectory(self.t, np.einsum("ij,njk->nik", A, self.T))

    def subset(self, idx: ArrayLike) -> "Trajectory":
        """The poses at the given indices (in that order)."""
        i = np.asarray(idx, dtype=np.int64)
        return Trajectory(self.t[i], self.T[i])

    def associate(
        self, ref: "Trajectory", max_diff_s: float = MAX_DIFF_S
    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Index pairs (i_self, i_ref) of nearest timestamps within ``max_diff_s``; each ref pose used once."""
        return associate(self.t, ref.t, max_diff_s)


def associate(
    t_est: ArrayLike, t_ref: ArrayLike, max_diff_s: float = MAX_DIFF_S
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Index pairs (i_est, i_ref) of nearest timestamps within ``max_diff_s``; each ref used once."""
    t_est = np.asarray(t_est, dtype=np.float64).reshape(-1)
    t_ref = np.asarray(t_ref, dtype=np.float64).reshape(-1)
    if len(t_est) == 0 or len(t_ref) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    order = np.argsort(t_ref, kind="stable")
    ts = t_ref[order]
    right = np.clip(np.searchsorted(ts, t_est), 1, len(ts) - 1) if len(ts) > 1 else np.zeros(len(t_est), int)
    left = np.maximum(right - 1, 0)
    pick = np.where(np.abs(t_est - ts[left]) <= np.abs(ts[right] - t_est), left, right)
    ok = np.abs(ts[pick] - t_est) <= max_diff_s
    i_est, i_ref = np.flatnonzero(ok), order[pick[ok]]
    _, first = np.unique(i_ref, return_index=True)
    keep = np.sort(first)
    return i_est[keep].astype(np.int64), i_ref[keep].astype(np.int64)
