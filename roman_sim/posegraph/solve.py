"""Robust multi-robot pose graph (gtsam, graduated non-convexity with truncated least squares).

Each robot contributes a keyframe chain built from its drifting odometry; loop closures
between submaps (intra- and inter-robot) attach to the keyframes at the submap centres.
Robots are tied together only through their own inter-robot closures: the first robot's
odometry frame is the common frame, every other robot is placed from a robust consensus of
all of its closures to robots already placed (``placement``), and robots no closure reaches
are reported as unconnected.

Odometry noise follows the reference (2 cm / 0.1 deg per edge at the full odometry rate,
``odom_ref_edge_m`` metres of travel per edge). Keyframe edges are longer, so their sigmas
are scaled by ``sqrt(edge_length / odom_ref_edge_m)``: the variance of a random-walk drift
grows linearly with the distance travelled, so chaining the full-rate edges would give the
same uncertainty.
"""

from __future__ import annotations

import logging
import time

import gtsam
import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import AlignResult
from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import inv_T
from roman_sim.mapping.types import Submap
from roman_sim.posegraph.build import GraphParts, build_graph
from roman_sim.posegraph.types import LoopClosure, PoseGraphConfig, PoseGraphResult, Trajectory

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
_LOSSES = {"TLS": gtsam.GncLossType.TLS, "GM": gtsam.GncLossType.GM}


def build_and_solve(
    trajectories: dict[str, Trajectory],
    submap_nodes: dict[str, list[tuple[float, F64]]],
    closures: list[LoopClosure],
    cfg: PoseGraphConfig | None = None,
) -> PoseGraphResult:
    """Build the multi-robot pose graph and solve it with GNC.

    Args:
        trajectories: robot -> full-rate odometry ``T_odom_body``; the first robot's odometry
            frame becomes the common frame.
        submap_nodes: robot -> [(t, T_odom_submap)] submap centres (list position = index).
        closures: measured loop closures; those with fewer than ``lc_association_thresh``
            associations are ignored.
        cfg: settings (defaults when None).

    Returns: the optimized trajectories, closure weights and unconnected robots.

    Raises:
        EvaluationError: inconsistent inputs (unknown robot, bad shapes, index out of range).
    """
    cfg = cfg or PoseGraphConfig()
    start = time.perf_counter()
    parts = build_graph(trajectories, submap_nodes, closures, cfg)
    initial = _initial_values(parts)
    values, weights = _optimize(parts, initial, cfg)
    result = _collect(trajectories, parts, values, weights, len(closures))
    result.runtime_s = time.perf_counter() - start
    result.info.update(
        n_nodes=float(initial.size()),
        n_factors=float(parts.graph.size()),
        error_initial=_weighted_error(parts.graph, initial, weights),
        error_final=_weighted_error(parts.graph, values, weights),
    )
    log.info(
        "pose graph: %d nodes, %d/%d closures inliers, %.2f s",
        initial.size(),
        result.n_inliers,
        len(parts.closure_factor),
        result.runtime_s,
    )
    return result


def _initial_values(parts: GraphParts) -> gtsam.Values:
    """Odometry keyframes moved by each robot's placement."""
    values = gtsam.Values()
    for robot, chain in parts.chains.items():
        for key, T in zip(chain.keys, chain.T_odom_kf):
            values.insert(key, gtsam.Pose3(parts.T_root_odom[robot] @ T))
    return values


def _optimize(parts: GraphParts, initial: gtsam.Values, cfg: PoseGraphConfig) -> tuple[gtsam.Values, F64]:
    """GNC over the closures (odometry and priors are known inliers); LM when no closure."""
    n = parts.graph.size()
    try:
        if not parts.closure_factor:
            return gtsam.LevenbergMarquardtOptimizer(parts.graph, initial).optimize(), np.ones(n)
        return _gnc(parts, initial, cfg)
    except RuntimeError as err:  # gtsam reports an ill-posed graph this way
        raise EvaluationError(f"pose graph could not be solved: {err}") from None


def _gnc(parts: GraphParts, initial: gtsam.Values, cfg: PoseGraphConfig) -> tuple[gtsam.Values, F64]:
    params = gtsam.GncLMParams(gtsam.LevenbergMarquardtParams())
    params.setLossType(_LOSSES[cfg.gnc_loss])
    params.maxIterations = cfg.max_iterations
    params.setKnownInliers(parts.known_inliers)
    optimizer = gtsam.GncLMOptimizer(parts.graph, initial, params)
    optimizer.setInlierCostThresholds(cfg.inlier_cost_threshold)
    values = optimizer.optimize()
    return values, np.asarray(optimizer.getWeights(), dtype=np.float64)


def _weighted_error(graph: gtsam.NonlinearFactorGraph, values: gtsam.Values, weights: F64) -> float:
    """Graph cost with each factor scaled by its final GNC weight (outliers count 0)."""
    return float(sum(w * graph.at(i).error(values) for i, w in enumerate(weights)))


def _collect(
    trajectories: dict[str, Trajectory],
    parts: GraphParts,
    values: gtsam.Values,
    weights: F64,
    n_closures: int,
) -> PoseGraphResult:
    """Interpolate full-rate poses and sort robots into connected and unconnected."""
    connected: dict[str, Trajectory] = {}
    loose: dict[str, Trajectory] = {}
    keyframes: dict[str, Trajectory] = {}
    for robot, odom in trajectories.items():
        chain = parts.chains[robot]
        T_kf = np.stack([values.atPose3(k).matrix() for k in chain.keys])
        keyframes[robot] = Trajectory(odom.t[chain.idx], T_kf)
        est = _apply_corrections(odom.T, chain.idx, chain.T_odom_kf, T_kf)
        target = connected if parts.root[robot] == parts.first else loose
        target[robot] = Trajectory(odom.t, est)
    closure_weights: list[float | None] = [None] * n_closures
    for ci, fi in parts.closure_factor.items():
        closure_weights[ci] = float(weights[fi])
    return PoseGraphResult(
        trajectories=connected,
        unconnected=list(loose),
        unconnected_trajectories=loose,
        closure_weights=closure_weights,
        keyframes=keyframes,
    )


def _apply_corrections(T_odom: F64, kf_idx: NDArray[np.int64], T_odom_kf: F64, T_est_kf: F64) -> F64:
    """Full-rate estimate: each sample takes the correction of the keyframe at or before it."""
    corrections = T_est_kf @ np.stack([inv_T(T) for T in T_odom_kf])
    owner = np.searchsorted(kf_idx, np.arange(len(T_odom)), side="right") - 1
    return corrections[np.clip(owner, 0, len(kf_idx) - 1)] @ T_odom


def submap_nodes_from(submaps: list[Submap]) -> dict[str, list[tuple[float, F64]]]:
    """``submap_nodes`` for ``build_and_solve`` from submaps (list position = ``Submap.index``).

    Raises:
        EvaluationError: a robot's submap indices are not 0..M-1.
    """
    nodes: dict[str, dict[int, tuple[float, F64]]] = {}
    for s in submaps:
        nodes.setdefault(s.robot, {})[int(s.index)] = (float(s.t), np.asarray(s.T_odom_submap, dtype=np.float64))
    out = {}
    for robot, by_index in nodes.items():
        if sorted(by_index) != list(range(len(by_index))):
            raise EvaluationError(f"submaps of {robot!r}: indices must be 0..{len(by_index) - 1}")
        out[robot] = [by_index[i] for i in range(len(by_index))]
    return out


def closure_from_alignment(a: Submap, b: Submap, result: AlignResult) -> LoopClosure | None:
    """The loop closure an alignment of submaps ``a`` and ``b`` proposes (None without a transform)."""
    if result.T_a_b is None:
        return None
    return LoopClosure.between(a, b, result.T_a_b, result.n_associations, result.method)
