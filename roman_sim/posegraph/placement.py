"""Robust placement of robots in a common frame from all of their inter-robot closures.

A closure between a robot ``r`` still to place and a robot ``p`` already placed implies a
pose of r's odometry frame in p's root frame, ``H = M @ inv(T_odom_node_r)``, where ``M`` is
the pose of r's closure keyframe that p's placed keyframe and the measurement give.
Placement is robust to wrong closures, whatever their association or inlier counts:

1. *Consensus* (exhaustive RANSAC over the few implied frames): a closure supports a
   hypothesis ``H`` when ``H`` predicts r's pose at the closure's own keyframe within the
   pose graph's inlier cost threshold, ``0.5 |w|^2 <= inlier_cost_threshold``, where ``w``
   is the 6-D residual (rotation vector, translation) whitened by the closure's sigmas and
   the odometry drift along r's chain between the two keyframes (``sigma^2`` grows with the
   distance ``d`` travelled: ``odom_sigma^2 * d / odom_ref_edge_m`` for rotation and
   translation, plus the lever arm of the heading drift, ``odom_sigma_rad^2 * d^3 / (3 *
   odom_ref_edge_m)``, for translation). The hypothesis with the most support wins (ties:
   lower summed cost, then the earlier closure). Counts are closures, so one method's
   inlier counts are never ranked against another's association counts.
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

from roman_sim.core.geometry import inv_T

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]


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


def _sigmas(c: Candidate, d_m: float, noise: NoiseModel) -> tuple[float, float]:
    """(rotation rad, translation m) sigma of ``c`` seen from a keyframe ``d_m`` away along r's chain."""
    per_m = 1.0 / noise.odom_ref_edge_m
    rot2 = c.sigma_rad**2 + noise.odom_sigma_rad**2 * d_m * per_m
    trans2 = c.sigma_m**2 + noise.odom_sigma_m**2 * d_m * per_m + noise.odom_sigma_rad**2 * d_m**3 * per_m / 3.0
    return float(np.sqrt(rot2)), float(np.sqrt(trans2))


def residual_cost(H: F64, c: Candidate, ref_dist_m: float, noise: NoiseModel) -> float:
    """``0.5 |w|^2`` of candidate ``c`` under the frame hypothesis ``H`` (see the module docstring)."""
    E = inv_T(c.M) @ H @ c.T_node
    rot = gtsam.Rot3.Logmap(gtsam.Rot3(E[:3, :3]))
    s_rot, s_trans = _sigmas(c, abs(c.dist_m - ref_dist_m), noise)
    return 0.5 * float(np.sum((rot / s_rot) ** 2) + np.sum((E[:3, 3] / s_trans) ** 2))


def consensus(cands: list[Candidate], noise: NoiseModel) -> tuple[int, list[int]]:
    """(winning candidate position, positions supporting it): most support, then lowest summed cost."""
    best_key: tuple[int, float, int] | None = None
    best_support: list[int] = []
    for h, hyp in enumerate(cands):
        H = hyp.frame
        costs = [residual_cost(H, c, hyp.dist_m, noise) for c in cands]
        support = [k for k, cost in enumerate(costs) if cost <= noise.inlier_cost_threshold]
        key = (-len(support), float(sum(costs[k] for k in support)), h)
        if best_key is None or key < best_key:
            best_key, best_support = key, support
    assert best_key is not None, "consensus needs at least one candidate"
    return best_key[2], best_support


def _refine(cands: list[Candidate], winner: int, support: list[int], noise: NoiseModel) -> tuple[F64, list[int]]:
    """GNC-TLS pose averaging of the implied frames from the winner; returns (frame, rejected positions)."""
    ref = cands[winner].dist_m
    graph = gtsam.NonlinearFactorGraph()
    for c in cands:
        s_rot, s_trans = _sigmas(c, abs(c.dist_m - ref), noise)
        cov_node = np.diag([s_rot**2] * 3 + [s_trans**2] * 3)
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
