"""The trajectory variants of a run: which pose graphs exist, their loop closures, and solving them.

The variants, in table order:

- ``odometry``: the drifting odometry, each robot placed with its true initial pose;
- ``odometry_no_prior``: the odometry with no start pose (each robot aligned by its own fit,
  which does not depend on where the robot is placed: it is scored from the ``odometry``
  trajectories);
- ``<method>``: the multi-robot pose graph with the chosen aligner's loop closures (every pair
  with a transform; the graph applies ``lc_association_thresh``);
- when the run also has the visual method (and the pose graph's method is another one),
  ``<visual label>`` (the visual closures alone) and ``combined`` (the method's accepted and
  the visual closures in one GNC graph, as the paper's Table I combines ROMAN with
  Kimera-Multi's visual loop closures); visual closures are already verified (at least the
  visual aligner's ``min_inliers`` 3D-3D inliers), so these graphs accept every closure;
- ``oracle``: the same graph with the true relative pose of every relevant pair (what loop
  closures can give at best).

A ``TrajectoryVariant`` (``roman_sim.evaluation.atetable``) is one row of the ATE table:
what it is, how it is fitted to the truth, whose trajectories it is scored from and, for a
pose graph, the closures it was given with their GNC weights. ``graph_variants`` decides which pose graphs exist,
``solve_variants`` solves them on the odometry and ``roman_sim.evaluation.atetable``
scores the variants.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from roman_sim.core.geometry import gravity_aligned
from roman_sim.core.jsontypes import JSON
from roman_sim.core.trajectory import Trajectory
from roman_sim.evaluation.atetable import Fit, TrajectoryVariant
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.evaluation.records import AlignmentRecord
from roman_sim.mapping.types import Submap
from roman_sim.posegraph import LoopClosure, PoseGraphConfig, build_and_solve, submap_nodes_from

#: Name of the true trajectories among the trajectory sources.
TRUTH = "truth"
#: Association count given to an oracle closure (above any acceptance threshold).
ORACLE_ASSOCIATIONS = 1_000_000
#: The variant name of the graph with both the method's and the visual closures.
COMBINED = "combined"
ORACLE = "oracle"


@dataclass(frozen=True)
class GraphInfo:
    """What one pose graph used: closures given, closures above the threshold, GNC inliers,
    robots no closure chain ties to the first robot."""

    closures: int
    closures_used: int
    inliers: int
    unconnected: list[str]


@dataclass
class TrajectoryEstimates:
    """Every variant with its trajectories (the ``posegraph`` stage's output).

    Attributes:
        trajectories: trajectory source (``truth``, ``odometry``, each graph) -> robot ->
            trajectory, the placed robots only, in scenario order.
        variants: variant name -> variant (graphs with their weights), in table order
            (empty when no pose graph was solved).
        graphs: graph name -> what it used.
        notes: statements for the report (unconnected robots, graphs without a closure).
        timings: each graph's solve time in s (``posegraph_s``); never saved.
    """

    trajectories: dict[str, dict[str, Trajectory]]
    variants: dict[str, TrajectoryVariant]
    graphs: dict[str, GraphInfo] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    timings: dict[str, JSON] = field(default_factory=dict, repr=False, compare=False)


def odometry_variants() -> dict[str, TrajectoryVariant]:
    """The two odometry rows: placed with the true start pose, and aligned robot by robot."""
    return {
        "odometry": TrajectoryVariant("odometry, each robot placed with its true start pose", "joint", "odometry"),
        "odometry_no_prior": TrajectoryVariant(
            "odometry without start poses, each robot aligned on its own", "per_robot", "odometry"
        ),
    }


def method_closures(
    submaps: Mapping[str, Submap], alignments: Iterable[AlignmentRecord], method: str
) -> list[LoopClosure]:
    """Loop closures proposed by ``method`` (every pair with a transform; the graph applies k), in alignment order.

    Args:
        submaps: submap name (``robot/index``) -> submap.
        alignments: every method's estimate per pair.
    """
    return [
        LoopClosure.between(submaps[r.a], submaps[r.b], r.T_a_b, r.n_associations, method)
        for r in alignments
        if r.method == method and r.T_a_b is not None
    ]


def oracle_closures(submaps: Mapping[str, Submap], truths: Mapping[tuple[str, str], PairTruth]) -> list[LoopClosure]:
    """The true relative pose of every relevant pair (pairs in name order)."""
    return [
        LoopClosure.between(submaps[a], submaps[b], t.T_a_b_true, ORACLE_ASSOCIATIONS, ORACLE)
        for (a, b), t in sorted(truths.items())
        if t.relevant
    ]


def graph_variants(
    method: str,
    visual: str | None,
    association_thresh: int,
    submaps: Sequence[Submap],
    alignments: Sequence[AlignmentRecord],
    truths: Mapping[tuple[str, str], PairTruth],
) -> dict[str, TrajectoryVariant]:
    """The pose graphs of a run with their closures, in table order (see the module docstring).

    Args:
        method: the pose graph's method label.
        visual: the label of the run's visual method (None: the run has none).
        association_thresh: the scenario's ``lc_association_thresh`` (the combined graph keeps
            the method's closures at or above it).
        submaps: every submap of the run.
        alignments: every method's estimate per pair.
        truths: the truth of each scored pair, keyed by (a name, b name).
    """
    subs = {s.name: s for s in submaps}
    own = method_closures(subs, alignments, method)
    out = {method: TrajectoryVariant(f"pose graph with {method}'s loop closures", source=method, closures=own)}
    if visual is not None and visual != method:
        seen = method_closures(subs, alignments, visual)
        accepted = [c for c in own if c.n_associations >= association_thresh]
        out[visual] = TrajectoryVariant(
            f"pose graph with {visual}'s visual loop closures", source=visual, closures=seen, association_thresh=0
        )
        out[COMBINED] = TrajectoryVariant(
            f"pose graph with {method}'s and {visual}'s loop closures",
            source=COMBINED,
            closures=accepted + seen,
            association_thresh=0,
        )
    out[ORACLE] = TrajectoryVariant(
        "pose graph with the true relative pose of every relevant pair",
        source=ORACLE,
        closures=oracle_closures(subs, truths),
    )
    return out


def solve_variants(
    odometry: Mapping[str, Trajectory],
    truth: Mapping[str, Trajectory],
    submaps: Sequence[Submap],
    graphs: Mapping[str, TrajectoryVariant],
    cfg: PoseGraphConfig,
) -> TrajectoryEstimates:
    """The odometry variants and every graph of ``graphs`` solved on the robots' odometry.

    Args:
        odometry: robot -> drifting odometry (every robot of the run, in scenario order).
        truth: robot -> true trajectory (the robots with truth).
        submaps: every submap of the run (the graphs' nodes).
        graphs: the pose graphs to solve (``graph_variants``), in table order.
        cfg: the scenario's pose-graph settings.
    """
    placed = {r: odometry[r].transformed(gravity_aligned(truth[r].T[0])) for r in truth}
    found = submap_nodes_from(list(submaps))
    nodes = {r: found.get(r, []) for r in odometry}
    out = TrajectoryEstimates({TRUTH: dict(truth), "odometry": placed}, odometry_variants())
    seconds: dict[str, JSON] = {}
    for name, graph in graphs.items():
        conf = cfg
        if graph.association_thresh is not None:
            conf = cfg.model_copy(update={"lc_association_thresh": graph.association_thresh})
        t0 = time.perf_counter()
        res = build_and_solve(dict(odometry), nodes, graph.closures, conf)
        seconds[name] = time.perf_counter() - t0
        used = [w for w in res.closure_weights if w is not None]
        out.graphs[name] = GraphInfo(len(graph.closures), len(used), res.n_inliers, list(res.unconnected))
        out.trajectories[name] = res.trajectories
        out.variants[name] = TrajectoryVariant(
            graph.description, graph.fit, graph.source, list(graph.closures), list(res.closure_weights)
        )
        if res.unconnected:
            out.notes.append(
                f"{name} pose graph: robot(s) {', '.join(res.unconnected)} never connected to the "
                f"first robot: placed {len(res.trajectories)} of {len(odometry)} robots"
            )
        if not used:
            out.notes.append(f"{name} pose graph: no loop closure accepted")
    out.timings["posegraph_s"] = seconds
    return out


@dataclass
class ClosureRow:
    """A loop closure and its weight in a solved variant (``VariantRow``): the transform as lists."""

    robot_a: str
    submap_a: int
    robot_b: str
    submap_b: int
    T_a_b: list[list[float]]
    n_associations: int
    sigma_m: float | None
    sigma_deg: float | None
    source: str
    weight: float | None

    @classmethod
    def of(cls, c: LoopClosure, weight: float | None) -> ClosureRow:
        """The row of ``c`` with its ``weight`` (floats round-trip exactly through JSON)."""
        T = np.asarray(c.T_a_b, dtype=np.float64).tolist()
        ids = (c.robot_a, int(c.submap_a), c.robot_b, int(c.submap_b))
        return cls(*ids, T, int(c.n_associations), c.sigma_m, c.sigma_deg, c.source, weight)

    def closure(self) -> LoopClosure:
        """Inverse of ``of`` (the weight apart)."""
        T = np.asarray(self.T_a_b, dtype=np.float64)
        ids = (self.robot_a, self.submap_a, self.robot_b, self.submap_b)
        return LoopClosure(*ids, T, self.n_associations, self.sigma_m, self.sigma_deg, self.source)


@dataclass
class VariantRow:
    """A solved trajectory variant as ``posegraph_estimates.json`` holds it (``variant_row``)."""

    name: str
    description: str
    fit: Fit
    source: str
    closures: list[ClosureRow]


def variant_row(name: str, v: TrajectoryVariant) -> VariantRow:
    """A variant's row: its name, description, fit, source and closures, each with its weight."""
    closures = [ClosureRow.of(c, w) for c, w in zip(v.closures, v.weights)]
    return VariantRow(name, v.description, v.fit, v.source, closures)


def variant_of_row(r: VariantRow) -> tuple[str, TrajectoryVariant]:
    """Inverse of ``variant_row``."""
    closures = [c.closure() for c in r.closures]
    return r.name, TrajectoryVariant(r.description, r.fit, r.source, closures, [c.weight for c in r.closures])


__all__ = [
    "COMBINED",
    "ClosureRow",
    "VariantRow",
    "ORACLE",
    "ORACLE_ASSOCIATIONS",
    "TRUTH",
    "GraphInfo",
    "TrajectoryEstimates",
    "graph_variants",
    "method_closures",
    "odometry_variants",
    "oracle_closures",
    "solve_variants",
    "variant_of_row",
    "variant_row",
]
