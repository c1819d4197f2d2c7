"""Synthetic multi-robot pose-graph scenarios with exact truth (no rendering needed).

Robots drive wobbly loops around a common centre with VIO-like drift (random walk in x, y,
z and yaw; roll and pitch stay exact), submap centres every few metres, and loop closures
between nearby submaps measured from the truth with small noise; a chosen fraction of the
closures are false (a plausible-looking transform between unrelated places). Used by the
pose-graph tests and benchmark, and by users stress-testing their own back end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydantic import Field
from scipy.spatial import cKDTree

from roman_sim.core.config import StrictModel
from roman_sim.core.geometry import gravity_aligned, inv_T, make_T, pose_4dof, pose_error, rot_z, rpy_to_R
from roman_sim.core.seeding import child_rng
from roman_sim.core.trajectory import Trajectory
from roman_sim.posegraph.types import LoopClosure

F64 = NDArray[np.float64]


class SyntheticGraphConfig(StrictModel):
    """Size, drift and closure mix of a synthetic scenario."""

    n_robots: int = Field(2, ge=1, le=50)
    length_m: float = Field(300.0, gt=10.0, le=100000.0)
    step_m: float = Field(1.0, gt=0.0, le=10.0)
    speed_mps: float = Field(1.0, gt=0.0, le=50.0)
    loop_radius_m: float = Field(40.0, gt=1.0, le=10000.0)
    submap_spacing_m: float = Field(10.0, gt=0.0, le=1000.0)
    drift_yaw_deg: float = Field(0.3, ge=0.0, le=10.0, description="yaw random walk per sqrt(m)")
    drift_yaw_bias_deg: float = Field(0.01, ge=-1.0, le=1.0, description="yaw bias per m")
    drift_xyz_m: float = Field(0.01, ge=0.0, le=1.0, description="position random walk per sqrt(m)")
    drift_scale: float = Field(0.01, ge=-0.5, le=0.5, description="odometry scale error")
    n_closures: int = Field(20, ge=0, le=100000)
    outlier_fraction: float = Field(0.0, ge=0.0, le=1.0)
    relevant_dist_m: float = Field(8.0, gt=0.0, le=100.0)
    closure_noise_m: float = Field(0.1, ge=0.0, le=10.0)
    closure_noise_deg: float = Field(1.0, ge=0.0, le=90.0)


@dataclass
class SyntheticGraph:
    """A scenario: truth, drifting odometry, submap centres and closures.

    Attributes:
        truth: robot -> true ``T_world_body`` trajectory.
        odom: robot -> drifting ``T_odom_body`` trajectory; odometry frame = gravity-aligned start.
        T_world_odom: robot -> 4x4 true pose of its odometry frame.
        submap_nodes: robot -> [(t, T_odom_submap)].
        T_world_submap: robot -> (M,4,4) true gravity-aligned submap poses.
        closures: inter- and intra-robot loop closures.
        closure_true: per closure, whether it is a correct measurement.
    """

    truth: dict[str, Trajectory]
    odom: dict[str, Trajectory]
    T_world_odom: dict[str, F64]
    submap_nodes: dict[str, list[tuple[float, F64]]]
    T_world_submap: dict[str, F64]
    closures: list[LoopClosure]
    closure_true: list[bool]


def _true_path(cfg: SyntheticGraphConfig, r: int) -> F64:
    """Poses (N,4,4) on a wobbly loop; robots differ in radius, phase and direction."""
    n = int(cfg.length_m / cfg.step_m) + 1
    radius = cfg.loop_radius_m + 3.0 * r
    sign = 1.0 if r % 2 == 0 else -1.0
    theta = sign * np.linspace(0.0, cfg.length_m / radius, n) + 0.7 * r
    rho = radius + 0.08 * radius * np.sin(3 * theta + r)
    xyz = np.column_stack([rho * np.cos(theta), rho * np.sin(theta), 0.5 * np.sin(2 * theta)])
    d = np.gradient(xyz, axis=0)
    yaw = np.arctan2(d[:, 1], d[:, 0])
    pitch = -np.arctan2(d[:, 2], np.linalg.norm(d[:, :2], axis=1))
    roll = np.deg2rad(2.0) * np.sin(theta * 5)
    return np.stack([make_T(rpy_to_R(ro, pi, ya), p) for ro, pi, ya, p in zip(roll, pitch, yaw, xyz)])


def _drift(cfg: SyntheticGraphConfig, T_true: F64, rng: np.random.Generator) -> tuple[F64, F64]:
    """Odometry in the gravity-aligned start frame; returns (T_world_odom, T_odom_body)."""
    T_world_odom = gravity_aligned(T_true[0])
    T_o = np.stack([inv_T(T_world_odom) @ T for T in T_true])
    out = T_o.copy()
    psi, pos = 0.0, T_o[0, :3, 3].copy()
    for i in range(1, len(T_o)):
        step = T_o[i, :3, 3] - T_o[i - 1, :3, 3]
        ds = float(np.linalg.norm(step))
        psi += np.deg2rad(cfg.drift_yaw_bias_deg * ds + cfg.drift_yaw_deg * np.sqrt(ds) * rng.normal())
        pos = pos + (1.0 + cfg.drift_scale) * rot_z(psi) @ step + cfg.drift_xyz_m * np.sqrt(ds) * rng.normal(size=3)
        out[i, :3, :3] = rot_z(psi) @ T_o[i, :3, :3]
        out[i, :3, 3] = pos
    return T_world_odom, out


def _submap_index(cfg: SyntheticGraphConfig, n: int) -> NDArray[np.int64]:
    every = max(int(round(cfg.submap_spacing_m / cfg.step_m)), 1)
    return np.arange(0, n, every)


def _candidates(cfg: SyntheticGraphConfig, T_ws: dict[str, F64]) -> list[tuple[str, int, str, int]]:
    """Relevant submap pairs: other robot, or same robot but not neighbours in sequence."""
    items = [(r, i) for r, Ts in T_ws.items() for i in range(len(Ts))]
    xyz = np.concatenate([Ts[:, :3, 3] for Ts in T_ws.values()])
    out = []
    for u, v in sorted(cKDTree(xyz).query_pairs(cfg.relevant_dist_m)):
        (ra, ia), (rb, ib) = items[u], items[v]
        if ra != rb or abs(ia - ib) >= 3:
            out.append((ra, ia, rb, ib))
    return out


def _false_T(T_true: F64, rng: np.random.Generator) -> F64:
    """A plausible transform (within 12 m, any yaw) at least 10 m or 60 deg from the truth.

    Closer errors would be explained by the reference loop-closure noise (2 m / 10 deg).
    """
    while True:
        x, y = rng.uniform(-12.0, 12.0, 2)
        T = pose_4dof(x, y, 0.0, rng.uniform(-np.pi, np.pi))
        rot, trans = pose_error(T, T_true)
        if trans > 10.0 or rot > np.deg2rad(60.0):
            return T


def _distinct_submaps(
    T_ws: dict[str, F64], robots: list[str], rng: np.random.Generator
) -> tuple[tuple[str, int], tuple[str, int]]:
    """Two different submaps, robots and indices drawn uniformly."""
    while True:
        ra, rb = (str(r) for r in rng.choice(robots, size=2))
        ia, ib = int(rng.integers(len(T_ws[ra]))), int(rng.integers(len(T_ws[rb])))
        if (ra, ia) != (rb, ib):
            return (ra, ia), (rb, ib)


def _closures(
    cfg: SyntheticGraphConfig, T_ws: dict[str, F64], rng: np.random.Generator
) -> tuple[list[LoopClosure], list[bool]]:
    cands = _candidates(cfg, T_ws)
    n_false = int(round(cfg.n_closures * cfg.outlier_fraction))
    n_true = min(cfg.n_closures - n_false, len(cands))
    closures: list[LoopClosure] = []
    is_true: list[bool] = []
    for k in rng.choice(len(cands), size=n_true, replace=False) if n_true else []:
        ra, ia, rb, ib = cands[k]
        dx, dy, dz = cfg.closure_noise_m * rng.normal(size=3)
        noise = pose_4dof(dx, dy, dz, np.deg2rad(cfg.closure_noise_deg) * rng.normal())
        T = inv_T(T_ws[ra][ia]) @ T_ws[rb][ib] @ noise
        closures.append(LoopClosure(ra, int(ia), rb, int(ib), T, int(rng.integers(6, 21)), source="synthetic"))
        is_true.append(True)
    robots = list(T_ws)
    for _ in range(n_false):
        (ra, ia), (rb, ib) = _distinct_submaps(T_ws, robots, rng)
        T = _false_T(inv_T(T_ws[ra][ia]) @ T_ws[rb][ib], rng)
        closures.append(LoopClosure(ra, ia, rb, ib, T, int(rng.integers(4, 11)), source="synthetic-false"))
        is_true.append(False)
    order = rng.permutation(len(closures))
    return [closures[i] for i in order], [is_true[i] for i in order]


def synthetic_scenario(seed: int, cfg: SyntheticGraphConfig | None = None) -> SyntheticGraph:
    """Generate a seeded scenario (same seed and config -> same arrays)."""
    cfg = cfg or SyntheticGraphConfig()
    truth, odom, T_wo, nodes, T_ws = {}, {}, {}, {}, {}
    for r in range(cfg.n_robots):
        name = f"robot{r}"
        T_true = _true_path(cfg, r)
        t = np.arange(len(T_true), dtype=np.float64) * cfg.step_m / cfg.speed_mps
        T_wo[name], T_odom = _drift(cfg, T_true, child_rng(seed, "posegraph_synthetic", "drift", name))
        truth[name], odom[name] = Trajectory(t, T_true), Trajectory(t, T_odom)
        idx = _submap_index(cfg, len(t))
        nodes[name] = [(float(t[i]), gravity_aligned(T_odom[i])) for i in idx]
        T_ws[name] = np.stack([gravity_aligned(T_true[i]) for i in idx])
    closures, flags = _closures(cfg, T_ws, child_rng(seed, "posegraph_synthetic", "closures"))
    return SyntheticGraph(truth, odom, T_wo, nodes, T_ws, closures, flags)
