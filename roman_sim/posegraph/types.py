"""Types of the multi-robot pose graph: its configuration, loop closures and results."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.core.trajectory import Trajectory
from roman_sim.mapping.types import Submap

F64 = NDArray[np.float64]


class PoseGraphConfig(StrictModel):
    """Noise models, GNC settings and loop-closure acceptance of the pose graph."""

    keyframe_spacing_m: float = Field(5.0, gt=0.0, le=1000.0)
    odom_sigma_m: float = Field(0.02, gt=0.0, le=10.0)
    odom_sigma_deg: float = Field(0.1, gt=0.0, le=90.0)
    odom_ref_edge_m: float = Field(0.2, gt=0.0, le=100.0)
    odom_min_edge_m: float = Field(0.05, gt=0.0, le=100.0)
    lc_sigma_m: float = Field(2.0, gt=0.0, le=100.0)
    lc_sigma_deg: float = Field(10.0, gt=0.0, le=180.0)
    prior_sigma_m: float = Field(1e-3, gt=0.0, le=1.0)
    prior_sigma_deg: float = Field(1e-3, gt=0.0, le=10.0)
    gnc_loss: Literal["TLS", "GM"] = "TLS"
    inlier_cost_threshold: float = Field(8.4, gt=0.0, le=1e6)
    max_iterations: int = Field(100, ge=1, le=10000)
    lc_association_thresh: int = Field(4, ge=0, le=10000)


@dataclass
class LoopClosure:
    """A measured relative pose between two submaps.

    Attributes:
        robot_a, robot_b: robot names.
        submap_a, submap_b: submap indices into the robots' ``submap_nodes`` lists.
        T_a_b: 4x4 pose of submap b's gravity-aligned frame in submap a's frame.
        n_associations: association count (the acceptance statistic; it never ranks closures).
        sigma_m, sigma_deg: per-closure noise override (None: the configured values).
        source: method that produced the closure (e.g. ``roman``, ``oracle``).
    """

    robot_a: str
    submap_a: int
    robot_b: str
    submap_b: int
    T_a_b: F64
    n_associations: int = 0
    sigma_m: float | None = None
    sigma_deg: float | None = None
    source: str = ""

    @classmethod
    def between(cls, a: Submap, b: Submap, T_a_b: ArrayLike, n_associations: int, source: str) -> LoopClosure:
        """The closure measuring submap ``b``'s frame in submap ``a``'s (``T_a_b``, 4x4) and its source."""
        return cls(
            a.robot,
            int(a.index),
            b.robot,
            int(b.index),
            np.asarray(T_a_b, dtype=np.float64),
            n_associations=int(n_associations),
            source=source,
        )

    @property
    def inter(self) -> bool:
        """Whether the closure joins two robots."""
        return self.robot_a != self.robot_b


@dataclass
class PoseGraphResult:
    """Outcome of ``build_and_solve``.

    Attributes:
        trajectories: robot -> trajectory in the first robot's odometry frame, for the
            robots connected to the first robot.
        unconnected: robots no inter-robot closure chain ties to the first robot.
        unconnected_trajectories: their optimized trajectories, each expressed in the
            odometry frame of the first robot of its own connected group.
        closure_weights: per input closure, the GNC inlier weight (about 1 inlier, about 0
            outlier), or None when the closure was not used (below the association
            threshold or degenerate).
        keyframes: robot -> optimized keyframes (same frames).
        runtime_s: wall time of building and solving.
    """

    trajectories: dict[str, Trajectory]
    unconnected: list[str]
    unconnected_trajectories: dict[str, Trajectory]
    closure_weights: list[float | None]
    keyframes: dict[str, Trajectory]
    runtime_s: float = 0.0
    info: dict[str, float] = field(default_factory=dict)

    @property
    def n_inliers(self) -> int:
        """Closures kept as inliers (weight > 0.5)."""
        return sum(1 for w in self.closure_weights if w is not None and w > 0.5)
