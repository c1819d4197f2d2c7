"""Robust multi-robot pose graph: ``types`` (configuration, closures, results), ``build``
(keyframe chains, closure factors), ``placement`` (each robot's frame from a robust consensus
of its closures), ``solve`` (gtsam GNC) and ``synthetic`` (pose-graph scenarios with exact
truth, no rendering).
"""

from roman_sim.posegraph.solve import build_and_solve, closure_from_alignment, submap_nodes_from
from roman_sim.posegraph.types import LoopClosure, PoseGraphConfig, PoseGraphResult, Trajectory

__all__ = [
    "LoopClosure",
    "PoseGraphConfig",
    "PoseGraphResult",
    "Trajectory",
    "build_and_solve",
    "closure_from_alignment",
    "submap_nodes_from",
]
