"""Absolute trajectory error (ATE): timestamp association, alignment, translation RMSE.

``se3`` alignment is Umeyama/Arun without scale, as evo's APE with ``--align``; ``4dof``
aligns yaw and translation only (gravity is observable, so this is the fair alignment for
VIO-like odometry; evo has no such mode); ``none`` compares the poses as given.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import arun, arun_4dof, transform_points
from roman_sim.core.trajectory import MAX_DIFF_S, Trajectory

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
Alignment = Literal["se3", "4dof", "none"]
#: Fewest associated poses an ATE is computed from.
MIN_POSES = 3
#: Key of the concatenated multi-robot result in ``multi_robot_ate``.
ALL = "all"


@dataclass
class AteResult:
    """Translation error statistics (metres) after alignment.

    Attributes:
        rmse_m, mean_m, median_m, max_m: statistics of the per-pose position errors.
        n: number of associated poses.
        alignment: the alignment used.
        T_align: 4x4 transform applied to the estimate (ref ~ T_align @ est).
    """

    rmse_m: float
    mean_m: float
    median_m: float
    max_m: float
    n: int
    alignment: str
    T_align: F64

    def to_dict(self) -> dict[str, float | int | str]:
        """JSON-ready statistics (without the alignment matrix)."""
        return {
            "rmse_m": self.rmse_m,
            "mean_m": self.mean_m,
            "median_m": self.median_m,
            "max_m": self.max_m,
            "n": self.n,
            "alignment": self.alignment,
        }


def _xyz(pts: ArrayLike, name: str) -> F64:
    arr = np.asarray(pts, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise EvaluationError(f"{name}: expected (N, 3) positions, got shape {arr.shape}")
    return arr


def align_se3(est_xyz: ArrayLike, ref_xyz: ArrayLike) -> F64:
    """Rigid transform (no scale) minimising ``|ref - T @ est|^2`` (Umeyama/Arun)."""
    est, ref = _xyz(est_xyz, "est_xyz"), _xyz(ref_xyz, "ref_xyz")
    _check_pair(est, ref)
    return arun(est, ref)


def align_4dof(est_xyz: ArrayLike, ref_xyz: ArrayLike) -> F64:
    """Yaw + translation transform minimising ``|ref - T @ est|^2`` (closed form)."""
    est, ref = _xyz(est_xyz, "est_xyz"), _xyz(ref_xyz, "ref_xyz")
    _check_pair(est, ref)
    return arun_4dof(est, ref)


def _no_alignment(est_xyz: ArrayLike, ref_xyz: ArrayLike) -> F64:
    return np.eye(4)


ALIGNMENTS: dict[str, Callable[[ArrayLike, ArrayLike], F64]] = {
    "se3": align_se3,
    "4dof": align_4dof,
    "none": _no_alignment,
}


def _check_pair(est: F64, ref: F64) -> None:
    if len(est) != len(ref):
        raise EvaluationError(f"ATE: {len(est)} estimated but {len(ref)} reference positions")
    if len(est) < MIN_POSES:
        raise EvaluationError(f"ATE: {len(est)} associated poses, at least {MIN_POSES} needed")


def _check_alignment(alignment: str) -> None:
    if alignment not in ALIGNMENTS:
        raise EvaluationError(f"ATE alignment {alignment!r} unknown (valid: {', '.join(ALIGNMENTS)})")


def _stats(est_xyz: F64, ref_xyz: F64, alignment: str) -> AteResult:
    _check_alignment(alignment)
    _check_pair(est_xyz, ref_xyz)
    T = ALIGNMENTS[alignment](est_xyz, ref_xyz)
    err = np.linalg.norm(ref_xyz - transform_points(T, est_xyz), axis=1)
    return AteResult(
        rmse_m=float(np.sqrt(np.mean(err**2))),
        mean_m=float(np.mean(err)),
        median_m=float(np.median(err)),
        max_m=float(np.max(err)),
        n=int(len(err)),
        alignment=alignment,
        T_align=T,
    )


def _matched_xyz(est: Trajectory, ref: Trajectory, max_diff_s: float, name: str) -> tuple[F64, F64]:
    i_e, i_r = est.associate(ref, max_diff_s)
    if len(i_e) < MIN_POSES:
        span_e = f"[{est.t.min():.3f}, {est.t.max():.3f}]" if len(est) else "[]"
        span_r = f"[{ref.t.min():.3f}, {ref.t.max():.3f}]" if len(ref) else "[]"
        raise EvaluationError(
            f"{name}: only {len(i_e)} poses matched in time (estimate {span_e} s, "
            f"reference {span_r} s, tolerance {max_diff_s} s); at least {MIN_POSES} needed"
        )
    return est.positions[i_e], ref.positions[i_r]


def ate_rmse(
    est: Trajectory, ref: Trajectory, alignment: Alignment = "se3", max_diff_s: float = MAX_DIFF_S
) -> AteResult:
    """ATE of an estimated trajectory against a reference (truth).

    Args:
        est: the estimate.
        ref: the reference.
        alignment: ``se3``, ``4dof`` or ``none``.
        max_diff_s: timestamp association tolerance.

    Raises:
        EvaluationError: fewer than 3 poses matched in time or unknown alignment.
    """
    _check_alignment(alignment)
    e, r = _matched_xyz(est, ref, max_diff_s, "ATE")
    return _stats(e, r, alignment)


def multi_robot_ate(
    est: Mapping[str, Trajectory],
    ref: Mapping[str, Trajectory],
    alignment: Alignment = "se3",
    max_diff_s: float = MAX_DIFF_S,
) -> dict[str, AteResult | None]:
    """Per-robot ATE (each robot aligned on its own) and ``"all"``: one alignment of the union.

    Robots of ``ref`` missing from ``est`` (e.g. never connected) or with too few matched
    poses get None (not computable) and are left out of ``"all"``; ``"all"`` is None when no
    robot is computable.

    Raises:
        EvaluationError: a robot of ``est`` has no reference, or a robot is named ``"all"``.
    """
    _check_alignment(alignment)
    if ALL in est or ALL in ref:
        raise EvaluationError(f"multi-robot ATE: a robot may not be named {ALL!r}")
    extra = sorted(set(est) - set(ref))
    if extra:
        raise EvaluationError(f"multi-robot ATE: no reference trajectory for {', '.join(extra)}")
    out: dict[str, AteResult | None] = {}
    est_all, ref_all = [], []
    for robot in ref:
        if robot not in est:
            log.warning("ATE: robot %s has no estimate; not computable", robot)
            out[robot] = None
            continue
        try:
            e, r = _matched_xyz(est[robot], ref[robot], max_diff_s, f"ATE {robot}")
            out[robot] = _stats(e, r, alignment)
        except EvaluationError as err:
            log.warning("%s; not computable", err)
            out[robot] = None
            continue
        est_all.append(e)
        ref_all.append(r)
    out[ALL] = _stats(np.concatenate(est_all), np.concatenate(ref_all), alignment) if est_all else None
    return out


def aligned_to_truth(est: Mapping[str, Trajectory], truth: Mapping[str, Trajectory]) -> dict[str, Trajectory]:
    """``est`` moved onto ``truth`` by one SE(3) fit of the concatenated robots (empty when not computable).

    Every robot of ``est`` must have a true trajectory in ``truth``.
    """
    if not est:
        return {}
    try:
        res = multi_robot_ate(est, {r: truth[r] for r in est}, "se3")[ALL]
    except EvaluationError:
        return {}
    return {} if res is None else {r: tr.transformed(res.T_align) for r, tr in est.items()}
