"""Robust placement of robots in a common frame from all of their inter-robot closures.

A closure between a robot ``r`` still to place and a robot ``p`` already placed implies a
pose of r's odometry frame in p's root frame, ``H = M @ inv(T_odom_node_r)``, where ``M`` is
the pose of r's closure keyframe that p's placed keyframe and the measurement give.
Placement is robust to wrong closures, whatever their association or inlier counts:

1. *Consensus* (RANSAC over the implied frames, exhaustive up to ``MAX_HYPOTHESES``): a
   closure supports a hypothesis ``H`` when ``H`` predicts r's pose at the closure's own
   keyframe within the pose graph's inlier cost threshold, ``0.5 |w|^2 <=
   inlier_cost_threshold``, where ``w`` is the 6-D residual (rotation vector, translation)
   whitened by the closure's sigmas and the odometry drift along r's chain between the two
   keyframes (``sigma^2`` grows with the distance ``d`` travelled: ``odom_sigma^2 * d /
   odom_ref_edge_m`` for rotation and translation, plus the lever arm of the heading drift,
   ``odom_sigma_rad^2 * d^3 / (3 * odom_ref_edge_m)``, for translation). The hypothesis
   with the most support wins (ties: lower summed cost, then the earlier closure). Counts
   are closures, so one method's inlier counts are never ranked against another's
   association counts.
2. *GNC refinement* (gtsam, truncated least squares): pose averaging over every implied
   frame, started at the winner, with the winner's supporters as known inliers; each
   frame's covariance is its keyframe-level noise moved to the odometry origin by the
   adjoint of the keyframe pose.

Robots are placed one at a time, the one with the largest consensus first; a robot no
closure reaches starts a group of its own. The pose graph's GNC then runs as before.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import gtsam
import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.geometry import inv_T

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
#: Frame hypotheses the consensus tries at most (every candidate votes on each).
MAX_HYPOTHESES = 200


@dataclass(frozen=True)
class NoiseModel:
    """The pose graph's noise settings that placement needs (metres, radians)."""

    odom_sigma_m: float
    odom_sigma_rad: float
    odom_ref_edge_m: float
    inlier_cost_threshold: float


@dataclass(frozen=True)
class Candidate:
    """One closure's view of where robot r's odometry frame lies.

    Attributes:
        closure: index of the closure in the caller's list.
        M: 4x4 pose of r's closure keyframe in the root frame (what the closure implies).
        T_node: 4x4 pose of that keyframe in r's odometry frame.
        dist_m: distance r had travelled at that keyframe.
        sigma_m, sigma_rad: the closure's own noise.
    """

    closure: int
    M: F64
    T_node: F64
    dist_m: float
    sigma_m: float
    sigma_rad: float

    @property
    def frame(self) -> F64:
        """The implied ``T_root_odom`` of robot r."""
        return self.M @ inv_T(self.T_node)


@dataclass
class Placement:
    """Where robot r's odometry frame lies in the root frame, and which closures agree.

    Attributes:
        T_root_odom: 4x4 estimate.
        support: closure indices of the winning consensus.
        candidates: every closure index that was considered.
        rejected: closures the GNC refinement gave a weight below 0.5.
    """

    T_root_odom: F64
    support: list[int]
    candidates: list[int]
    rejected: list[int] = field(default_factory=list)


def _sigmas(
    sigma_rad: F64, sigma_m: F64, d_m: F64, noise: NoiseModel
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(rotation rad, translation m) sigmas of closures seen from keyframes ``d_m`` away along r's chain."""
    per_m = 1.0 / noise.odom_ref_edge_m
    rot2 = sigma_rad**2 + noise.odom_sigma_rad**2 * d_m * per_m
    trans2 = sigma_m**2 + noise.odom_sigma_m**2 * d_m * per_m + noise.odom_sigma_rad**2 * d_m**3 * per_m / 3.0
    return np.sqrt(rot2), np.sqrt(trans2)


@dataclass(frozen=True)
class _Stack:
    """The candidates as arrays: inv(M) (K, 4, 4), keyframe poses (K, 4, 4), distances and sigmas (K,)."""

    M_inv: F64
    T_node: F64
    dist: F64
    sigma_m: F64
    sigma_rad: F64

    @classmethod
    def of(cls, cands: list[Candidate]) -> "_Stack":
        return cls(
            np.stack([inv_T(c.M) for c in cands]),
            np.stack([c.T_node for c in cands]),
            np.array([c.dist_m for c in cands]),
            np.array([c.sigma_m for c in cands]),
            np.array([c.sigma_rad for c in cands]),
        )


def residual_costs(H: F64, st: _Stack, ref_dist_m: float, noise: NoiseModel) -> F64:
    """``0.5 |w|^2`` of every candidate under the frame hypothesis ``H`` (see the module docstring)."""
    E = st.M_inv @ H @ st.T_node
    rot = Rotation.from_matrix(E[:, :3, :3]).as_rotvec()
    s_rot, s_trans = _sigmas(st.sigma_rad, st.sigma_m, np.abs(st.dist - ref_dist_m), noise)
    return 0.5 * (np.sum((rot / s_rot[:, None]) ** 2, axis=1) + np.sum((E[:, :3, 3] / s_trans[:, None]) ** 2, axis=1))


def consensus(cands: list[Candidate], noise: NoiseModel) -> tuple[int, list[int]]:
    """(winning candidate position, positions supporting it): most support, then lowest summed cost.

    Every candidate is a hypothesis up to ``MAX_HYPOTHESES``; beyond, that many evenly spread ones
    (in closure order) are tried, and every candidate still votes.
    """
    st = _Stack.of(cands)
    hyps = np.unique(np.linspace(0, len(cands) - 1, min(len(cands), MAX_HYPOTHESES)).round().astype(int))
    best_key: tuple[int, float, int] | None = None
    best_support: list[int] = []
    for h in hyps.tolist():
        costs = residual_costs(cands[h].frame, st, cands[h].dist_m, noise)
        inl = costs <= noise.inlier_cost_threshold
        key = (-int(inl.sum()), float(costs[inl].sum()), h)
        if best_key is None or key < best_key:
            best_key, best_support = key, np.flatnonzero(inl).tolist()
    assert best_key is not None, "consensus needs at least one candidate"
    return best_key[2], best_support


def _refine(cands: list[Candidate], winner: int, support: list[int], noise: NoiseModel) -> tuple[F64, list[int]]:
    """GNC-TLS pose averaging of the implied frames from the winner; returns (frame, rejected positions)."""
    st = _Stack.of(cands)
    s_rot, s_trans = _sigmas(st.sigma_rad, st.sigma_m, np.abs(st.dist - cands[winner].dist_m), noise)
    graph = gtsam.NonlinearFactorGraph()
    for k, c in enumerate(cands):
        cov_node = np.diag([s_rot[k] ** 2] * 3 + [s_trans[k] ** 2] * 3)
        ad = gtsam.Pose3(c.T_node).AdjointMap()
        cov = ad @ cov_node @ ad.T
        graph.add(gtsam.PriorFactorPose3(0, gtsam.Pose3(c.frame), gtsam.noiseModel.Gaussian.Covariance(cov)))
    initial = gtsam.Values()
    initial.insert(0, gtsam.Pose3(cands[winner].frame))
    params = gtsam.GncLMParams(gtsam.LevenbergMarquardtParams())
    params.setLossType(gtsam.GncLossType.TLS)
    params.setKnownInliers(support)
    optimizer = gtsam.GncLMOptimizer(graph, initial, params)
    optimizer.setInlierCostThresholds(noise.inlier_cost_threshold)
    try:
        est = optimizer.optimize().atPose3(0).matrix()
        weights = np.asarray(optimizer.getWeights(), dtype=np.float64)
    except RuntimeError as err:  # an ill-conditioned average: keep the consensus frame
        log.debug("placement refinement failed (%s); the consensus frame is kept", err)
        return cands[winner].frame, []
    return est, [k for k, w in enumerate(weights) if w < 0.5]


def place_robot(cands: list[Candidate], noise: NoiseModel) -> Placement:
    """Robust ``T_root_odom`` of one robot from its candidates (at least one)."""
    winner, support = consensus(cands, noise)
    ids = [c.closure for c in cands]
    if len(cands) == 1:
        return Placement(cands[0].frame, ids, ids)
    T, rejected = _refine(cands, winner, support, noise)
    return Placement(T, [ids[k] for k in support], ids, [ids[k] for k in rejected])
