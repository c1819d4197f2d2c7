"""Factor-graph construction for ``roman_sim.posegraph``: keyframe chains, closure factors,
and the robust placement of each robot from all of its inter-robot closures (``placement``).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import gtsam
import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import inv_T
from roman_sim.core.trajectory import Trajectory
from roman_sim.posegraph.placement import Candidate, NoiseModel, Placement, place_robot

if TYPE_CHECKING:
    from roman_sim.posegraph.types import LoopClosure, PoseGraphConfig

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
#: Submap times may lie this far outside a robot's trajectory (s) and still snap to its ends.
TIME_TOLERANCE_S = 1.0


@dataclass
class Chain:
    """One robot's keyframes: gtsam keys, sample indices, odometry poses (K, 4, 4) and the
    distance travelled at each (K,)."""

    keys: list[int]
    idx: NDArray[np.int64]
    T_odom_kf: F64
    dist_m: F64


@dataclass
class Edge:
    """An accepted closure between keyframe nodes: ``Z`` is T_nodeA_nodeB, with its noise (m, deg)."""

    closure: int
    robot_a: str
    pos_a: int
    robot_b: str
    pos_b: int
    Z: F64
    sigma_m: float
    sigma_deg: float


@dataclass
class GraphParts:
    """The factor graph and what is needed to read it back."""

    graph: gtsam.NonlinearFactorGraph
    chains: dict[str, Chain]
    closure_factor: dict[int, int] = field(default_factory=dict)
    known_inliers: list[int] = field(default_factory=list)
    first: str = ""
    root: dict[str, str] = field(default_factory=dict)
    T_root_odom: dict[str, F64] = field(default_factory=dict)
    placements: dict[str, Placement] = field(default_factory=dict)


def _sigmas(sigma_m: float, sigma_deg: float) -> gtsam.noiseModel.Diagonal:
    r = np.deg2rad(sigma_deg)
    return gtsam.noiseModel.Diagonal.Sigmas(np.array([r, r, r, sigma_m, sigma_m, sigma_m]))


def _check_trajectory(robot: str, traj: object) -> tuple[F64, F64]:
    """Times and poses of a robot's odometry (a ``Trajectory`` with >= 1 pose, strictly increasing times)."""
    if not isinstance(traj, Trajectory):
        raise EvaluationError(f"trajectory {robot!r}: expected a Trajectory, got {type(traj).__name__}")
    if len(traj) == 0:
        raise EvaluationError(f"trajectory {robot!r}: no poses")
    if np.any(np.diff(traj.t) <= 0):
        raise EvaluationError(f"trajectory {robot!r}: timestamps must be strictly increasing")
    return traj.t, traj.T


def _keyframe_indices(T: F64, node_idx: NDArray[np.int64], spacing_m: float) -> NDArray[np.int64]:
    """Every ``spacing_m`` of travelled distance, plus first, last and submap-centre samples."""
    steps = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
    dist = np.concatenate([[0.0], np.cumsum(steps)])
    bins = np.floor(dist / spacing_m).astype(np.int64)
    spaced = np.flatnonzero(np.diff(bins, prepend=-1))
    return np.unique(np.concatenate([spaced, node_idx, [0, len(T) - 1]]).astype(np.int64))


def _submap_samples(robot: str, t: F64, nodes: list[tuple[float, F64]]) -> NDArray[np.int64]:
    times = np.array([float(n[0]) for n in nodes], dtype=np.float64)
    if len(times) and (times.min() < t[0] - TIME_TOLERANCE_S or times.max() > t[-1] + TIME_TOLERANCE_S):
        raise EvaluationError(
            f"submap_nodes {robot!r}: submap times outside the trajectory [{t[0]:.3f}, {t[-1]:.3f}] s"
        )
    right = np.clip(np.searchsorted(t, times), 1, len(t) - 1) if len(t) > 1 else np.zeros(len(times), int)
    left = np.maximum(right - 1, 0)
    nearer_left = np.abs(times - t[left]) <= np.abs(t[right] - times)
    return np.where(nearer_left, left, right).astype(np.int64)


def _chains(
    trajectories: dict, submap_nodes: dict, cfg: "PoseGraphConfig", graph: gtsam.NonlinearFactorGraph
) -> tuple[dict[str, Chain], dict[tuple[str, int], tuple[int, F64]], list[int]]:
    """Keyframe chains with odometry factors; maps (robot, submap) -> (chain position, T_kf_submap)."""
    chains, anchors, odom_factors = {}, {}, []
    key = 0
    for robot, traj in trajectories.items():
        t, T = _check_trajectory(robot, traj)
        nodes = submap_nodes.get(robot, [])
        sample = _submap_samples(robot, t, nodes)
        idx = _keyframe_indices(T, sample, cfg.keyframe_spacing_m)
        steps = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
        dist = np.concatenate([[0.0], np.cumsum(steps)])
        chain = Chain(keys=list(range(key, key + len(idx))), idx=idx, T_odom_kf=T[idx], dist_m=dist[idx])
        key += len(idx)
        chains[robot] = chain
        for k in range(len(idx) - 1):
            length = max(dist[idx[k + 1]] - dist[idx[k]], cfg.odom_min_edge_m)
            scale = np.sqrt(length / cfg.odom_ref_edge_m)
            Z = inv_T(chain.T_odom_kf[k]) @ chain.T_odom_kf[k + 1]
            odom_factors.append(graph.size())
            graph.add(
                gtsam.BetweenFactorPose3(
                    chain.keys[k],
                    chain.keys[k + 1],
                    gtsam.Pose3(Z),
                    _sigmas(cfg.odom_sigma_m * scale, cfg.odom_sigma_deg * scale),
                )
            )
        pos = np.searchsorted(idx, sample)
        for s, (_, T_sub) in enumerate(nodes):
            T_sub = np.asarray(T_sub, dtype=np.float64)
            if T_sub.shape != (4, 4) or not np.all(np.isfinite(T_sub)):
                raise EvaluationError(f"submap_nodes {robot!r}[{s}]: T_odom_submap must be a finite 4x4")
            anchors[(robot, s)] = (int(pos[s]), inv_T(chain.T_odom_kf[pos[s]]) @ T_sub)
    return chains, anchors, odom_factors


def _edges(closures: list["LoopClosure"], anchors: dict, chains: dict, cfg: "PoseGraphConfig") -> list[Edge]:
    """Accepted closures (at least ``lc_association_thresh`` associations) as keyframe-to-keyframe measurements."""
    edges = []
    for ci, lc in enumerate(closures):
        for robot, sub in ((lc.robot_a, lc.submap_a), (lc.robot_b, lc.submap_b)):
            if robot not in chains:
                raise EvaluationError(f"closure {ci}: unknown robot {robot!r} (known: {', '.join(chains)})")
            if (robot, sub) not in anchors:
                raise EvaluationError(f"closure {ci}: robot {robot!r} has no submap {sub}")
        T_a_b = np.asarray(lc.T_a_b, dtype=np.float64)
        if T_a_b.shape != (4, 4) or not np.all(np.isfinite(T_a_b)):
            raise EvaluationError(f"closure {ci}: T_a_b must be a finite 4x4 matrix")
        for name in ("sigma_m", "sigma_deg"):
            value = getattr(lc, name)
            if value is not None and not (np.isfinite(value) and value > 0):
                raise EvaluationError(f"closure {ci}: {name} must be a positive number or None, got {value}")
        if lc.n_associations < cfg.lc_association_thresh:
            continue
        pos_a, T_na_sa = anchors[(lc.robot_a, lc.submap_a)]
        pos_b, T_nb_sb = anchors[(lc.robot_b, lc.submap_b)]
        if lc.robot_a == lc.robot_b and pos_a == pos_b:
            log.warning("closure %d joins a keyframe to itself; ignored", ci)
            continue
        Z = T_na_sa @ T_a_b @ inv_T(T_nb_sb)
        sigma_m = cfg.lc_sigma_m if lc.sigma_m is None else lc.sigma_m
        sigma_deg = cfg.lc_sigma_deg if lc.sigma_deg is None else lc.sigma_deg
        edges.append(Edge(ci, lc.robot_a, pos_a, lc.robot_b, pos_b, Z, float(sigma_m), float(sigma_deg)))
    return edges


def _candidates(robot: str, inter: list[Edge], chains: dict[str, Chain], parts: GraphParts) -> list[Candidate]:
    """What each closure between ``robot`` and a placed robot implies about ``robot``'s frame."""
    out = []
    for e in inter:
        if e.robot_b == robot and e.robot_a in parts.root:
            other, pos_o, pos_r, Z = e.robot_a, e.pos_a, e.pos_b, e.Z
        elif e.robot_a == robot and e.robot_b in parts.root:
            other, pos_o, pos_r, Z = e.robot_b, e.pos_b, e.pos_a, inv_T(e.Z)
        else:
            continue
        M = parts.T_root_odom[other] @ chains[other].T_odom_kf[pos_o] @ Z
        chain = chains[robot]
        out.append(
            Candidate(
                e.closure, M, chain.T_odom_kf[pos_r], float(chain.dist_m[pos_r]), e.sigma_m, np.deg2rad(e.sigma_deg)
            )
        )
    return out


def _place(
    robots: list[str], edges: list[Edge], chains: dict[str, Chain], parts: GraphParts, noise: NoiseModel
) -> None:
    """Place robots one at a time, each from a robust consensus of its closures to placed robots.

    The robot whose consensus is largest goes first (ties: scenario order); a robot no closure
    reaches roots a group of its own.
    """
    parts.first = robots[0]
    inter = [e for e in edges if e.robot_a != e.robot_b]
    cache: dict[str, tuple[tuple[int, ...], Placement]] = {}  # a candidate's frame is fixed once its robot is
    while len(parts.root) < len(robots):
        best: tuple[int, str, Placement] | None = None
        for r in robots:
            cands = [] if r in parts.root else _candidates(r, inter, chains, parts)
            if not cands:
                continue
            ids = tuple(c.closure for c in cands)
            if r not in cache or cache[r][0] != ids:
                cache[r] = (ids, place_robot(cands, noise))
            pl = cache[r][1]
            if best is None or len(pl.support) > best[0]:
                best = (len(pl.support), r, pl)
        if best is None:
            new = next(r for r in robots if r not in parts.root)
            parts.root[new], parts.T_root_odom[new] = new, np.eye(4)
            continue
        _, r, pl = best
        anchor = next(e for e in inter if e.closure == pl.support[0])
        parts.root[r] = parts.root[anchor.robot_a if anchor.robot_b == r else anchor.robot_b]
        parts.T_root_odom[r], parts.placements[r] = pl.T_root_odom, pl
        log.info(
            "robot %s placed from %d of %d closures (rejected by the refinement: %d)",
            r,
            len(pl.support),
            len(pl.candidates),
            len(pl.rejected),
        )


def build_graph(
    trajectories: dict, submap_nodes: dict, closures: list["LoopClosure"], cfg: "PoseGraphConfig"
) -> GraphParts:
    """Odometry chains, closure factors, robot placement and one prior per connected group."""
    if not trajectories:
        raise EvaluationError("pose graph: no trajectories given")
    unknown = sorted(set(submap_nodes) - set(trajectories))
    if unknown:
        raise EvaluationError(f"submap_nodes: robots without a trajectory: {', '.join(unknown)}")
    graph = gtsam.NonlinearFactorGraph()
    chains, anchors, odom_factors = _chains(trajectories, submap_nodes, cfg, graph)
    parts = GraphParts(graph=graph, chains=chains, known_inliers=list(odom_factors))
    edges = _edges(closures, anchors, chains, cfg)
    for e in edges:
        noise = _sigmas(e.sigma_m, e.sigma_deg)
        parts.closure_factor[e.closure] = graph.size()
        graph.add(
            gtsam.BetweenFactorPose3(
                chains[e.robot_a].keys[e.pos_a], chains[e.robot_b].keys[e.pos_b], gtsam.Pose3(e.Z), noise
            )
        )
    placement_noise = NoiseModel(
        cfg.odom_sigma_m, float(np.deg2rad(cfg.odom_sigma_deg)), cfg.odom_ref_edge_m, cfg.inlier_cost_threshold
    )
    _place(list(trajectories), edges, chains, parts, placement_noise)
    prior = _sigmas(cfg.prior_sigma_m, cfg.prior_sigma_deg)
    for robot, root in parts.root.items():
        if robot == root:
            parts.known_inliers.append(graph.size())
            graph.add(gtsam.PriorFactorPose3(chains[robot].keys[0], gtsam.Pose3(chains[robot].T_odom_kf[0]), prior))
    return parts
