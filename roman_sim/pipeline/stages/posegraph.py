"""Stage ``posegraph``: pose graphs of the run and their trajectory errors.

Three trajectories per robot are scored against the truth:

- ``odometry``: the drifting odometry, each robot placed with its true initial pose;
- ``<method>``: the multi-robot pose graph with the chosen aligner's loop closures;
- ``oracle``: the same pose graph with the true relative pose of every relevant pair (the
  upper bound of what loop closures can give).

When the scenario also runs the visual method (and the pose graph's method is another
one), two more: ``<visual label>`` (the visual closures alone) and ``combined`` (the
method's and the visual closures in one GNC graph, as the paper's Table I combines ROMAN
with Kimera-Multi's visual loop closures). Visual closures are those the visual aligner
accepted (at least its ``min_inliers`` 3D-3D inliers); the method's keep
``lc_association_thresh``.

Writes ``ate.json`` (the ATE table and the stage's notes), ``posegraph.json`` (closures
used and robots left unconnected per graph), ``trajectories/<robot>.<variant>.tum`` and
``plots/trajectories.png``.
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import EvaluationError, StorageError
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import write_tum
from roman_sim.evaluation.ate import multi_robot_ate
from roman_sim.evaluation.trajplot import plot_trajectories
from roman_sim.evaluation.types import AteTable
from roman_sim.geometry import gravity_aligned, pose_error
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.scenario import VISUAL_METHODS
from roman_sim.pipeline.stages.base import Stage, rel
from roman_sim.pipeline.stages.evaluation import EvaluationOutput
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.posegraph import LoopClosure, build_and_solve, submap_nodes_from

log = logging.getLogger(__name__)

ATE_JSON = "ate.json"
POSEGRAPH_JSON = "posegraph.json"
PLOT = "plots/trajectories.png"
ORACLE_ASSOCIATIONS = 1_000_000
ALIGNMENTS = ("se3", "4dof")


@dataclass(frozen=True)
class GraphInfo:
    """What one pose graph used: closures given, closures above the threshold, GNC inliers,
    robots no closure chain ties to the first robot."""

    closures: int
    closures_used: int
    inliers: int
    unconnected: list[str]


@dataclass
class PoseGraphOutput:
    """ATE table, per-graph information, trajectories per variant and robot, notes.

    ``written`` lists the trajectory files and plot the run wrote (not persisted).
    """

    ate: AteTable
    graphs: dict[str, GraphInfo]
    notes: list[str] = field(default_factory=list)
    written: list[str] = field(default_factory=list, repr=False)


def method_closures(submaps: Submaps, evaluation: EvaluationOutput, method: str) -> list[LoopClosure]:
    """Loop closures proposed by ``method`` (every pair with a transform; the graph applies k)."""
    subs = submaps.by_name()
    out = []
    for r in evaluation.alignments:
        if r.method != method or r.T_a_b is None:
            continue
        a, b = subs[r.a], subs[r.b]
        out.append(LoopClosure(a.robot, a.index, b.robot, b.index, np.asarray(r.T_a_b, dtype=np.float64),
                               n_associations=r.n_associations, source=method))
    return out


def oracle_closures(submaps: Submaps, evaluation: EvaluationOutput) -> list[LoopClosure]:
    """True relative poses of every relevant pair."""
    subs = submaps.by_name()
    out = []
    for (a_name, b_name), t in sorted(evaluation.truths().items()):
        if t.relevant:
            a, b = subs[a_name], subs[b_name]
            out.append(LoopClosure(a.robot, a.index, b.robot, b.index, np.asarray(t.T_a_b_true),
                                   n_associations=ORACLE_ASSOCIATIONS, source="oracle"))
    return out


def graph_variants(ctx: RunContext, submaps: Submaps, evaluation: EvaluationOutput, method: str
                   ) -> list[tuple[str, list[LoopClosure], int]]:
    """(variant, closures, association threshold) of every pose graph to solve, in table order."""
    thresh = ctx.scenario.posegraph.lc_association_thresh
    own = method_closures(submaps, evaluation, method)
    out = [(method, own, thresh)]
    visual = next((a.name for a in ctx.scenario.aligners if a.method in VISUAL_METHODS), None)
    if visual is not None and visual != method:
        vis = method_closures(submaps, evaluation, visual)
        out += [(visual, vis, 0), ("combined", [c for c in own if c.n_associations >= thresh] + vis, 0)]
    return [*out, ("oracle", oracle_closures(submaps, evaluation), thresh)]


def score(est: dict[str, Trajectory], ref: dict[str, Trajectory]) -> dict[str, dict[str, float | None]]:
    """Per alignment: RMSE per robot and of the concatenation (``all``); None where not computable."""
    out = {}
    for alignment in ALIGNMENTS:
        try:
            res = multi_robot_ate(est, ref, alignment)  # type: ignore[arg-type]
        except EvaluationError as err:
            log.warning("ATE (%s) not computable: %s", alignment, err)
            res = {}
        table = {k: (None if v is None else v.rmse_m) for k, v in res.items()}
        table.setdefault("all", None)
        out[alignment] = table
    return out


def _closure_lines(ctx: RunContext, submaps: Submaps, closures: list[LoopClosure], weights: list[Any]) -> list[Any]:
    subs = submaps.by_name()
    thresh = ctx.scenario.posegraph.lc_association_thresh
    ev = ctx.scenario.evaluation
    lines = []
    for c, w in zip(closures, weights):
        if w is None or c.n_associations < thresh:
            continue
        a, b = subs[f"{c.robot_a}/{c.submap_a}"], subs[f"{c.robot_b}/{c.submap_b}"]
        assert a.truth is not None and b.truth is not None
        Ta, Tb = a.truth.T_world_submap, b.truth.T_world_submap
        rot, trans = pose_error(c.T_a_b, np.linalg.inv(Ta) @ Tb)
        ok = math.degrees(rot) <= ev.rot_tol_deg and trans <= ev.trans_tol_m
        lines.append((Ta[:3, 3], Tb[:3, 3], "inter" if c.inter else "intra", bool(ok)))
    return lines


def _aligned(est: dict[str, Trajectory], truth: dict[str, Trajectory]) -> dict[str, Trajectory]:
    """The estimate moved onto the truth by the concatenated SE(3) alignment (empty if impossible)."""
    if not est:
        return {}
    try:
        res = multi_robot_ate(est, {r: truth[r] for r in est}, "se3")["all"]
    except EvaluationError:
        return {}
    return {} if res is None else {r: tr.transformed(res.T_align) for r, tr in est.items()}


class PoseGraphStage(Stage[PoseGraphOutput]):
    """Solve the odometry-only, method (visual, combined) and oracle pose graphs and score their trajectories."""

    name = "posegraph"
    inputs = ("maps", "submaps", "evaluation")

    def config_parts(self, ctx: RunContext) -> list[Any]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["posegraph"], sc["posegraph_method"], sc["evaluation"]]

    def run(self, ctx: RunContext, maps: Maps | None = None, submaps: Submaps | None = None,
            evaluation: EvaluationOutput | None = None, **_: Any) -> PoseGraphOutput:
        assert submaps is not None and evaluation is not None
        method = ctx.scenario.posegraph_method
        if method is None:
            return PoseGraphOutput(AteTable(), {}, ["pose graph skipped: no posegraph_method"])
        if maps is None:
            return PoseGraphOutput(AteTable(), {}, ["pose graph skipped: no trajectories (run started from saved submaps)"])
        truth = {r: m.truth for r, m in maps.maps.items() if m.truth is not None}
        odom = {r: m.odometry for r, m in maps.maps.items()}
        placed = {r: odom[r].transformed(gravity_aligned(truth[r].T[0])) for r in truth}
        nodes = submap_nodes_from(submaps.all())
        nodes = {r: nodes.get(r, []) for r in maps.maps}
        table = {"odometry": score(placed, truth)}
        graphs, notes, written, seconds = {}, [], [], {}
        trajectories: dict[str, dict[str, Trajectory]] = {"truth": truth, "odometry": placed}
        for variant, closures, thresh in graph_variants(ctx, submaps, evaluation, method):
            t0 = time.perf_counter()
            cfg = ctx.scenario.posegraph.model_copy(update={"lc_association_thresh": thresh})
            res = build_and_solve(odom, nodes, closures, cfg)
            seconds[variant] = time.perf_counter() - t0
            table[variant] = score(res.trajectories, truth)
            used = [w for w in res.closure_weights if w is not None]
            graphs[variant] = GraphInfo(len(closures), len(used), res.n_inliers, list(res.unconnected))
            trajectories[variant] = res.trajectories
            if res.unconnected:
                notes.append(f"{variant} pose graph: robot(s) {', '.join(res.unconnected)} never connected "
                             "to the first robot; their ATE is not computable")
            if not used:
                notes.append(f"{variant} pose graph: no loop closure accepted")
            if variant == method:
                lines = _closure_lines(ctx, submaps, closures, res.closure_weights)
                est_world = _aligned(res.trajectories, truth)
        ctx.timings["posegraph_s"] = seconds
        for variant, per in trajectories.items():
            for r, tr in per.items():
                path = ctx.run_dir / "trajectories" / f"{r}.{variant}.tum"
                write_tum(path, tr)
                written.append(rel(ctx, path))
        try:
            plot_trajectories(ctx.run_dir / PLOT, truth, est=est_world or None, odom=placed, closures=lines,
                              title=f"{ctx.scenario.name}: truth, odometry and {method} pose graph")
            written.append(PLOT)
        except EvaluationError as err:
            notes.append(f"trajectory plot not drawn: {err}")
        return PoseGraphOutput(AteTable(table), graphs, notes, sorted(written))

    def save(self, out: PoseGraphOutput, ctx: RunContext) -> list[str]:
        write_json(ctx.run_dir / ATE_JSON, {**out.ate.to_json(), "notes": out.notes})
        write_json(ctx.run_dir / POSEGRAPH_JSON, {k: vars(v) for k, v in out.graphs.items()})
        return [ATE_JSON, POSEGRAPH_JSON, *out.written]

    def load(self, ctx: RunContext, files: list[str]) -> PoseGraphOutput:
        try:
            ate_data = json.loads((ctx.run_dir / ATE_JSON).read_text(encoding="utf-8"))
            graphs = json.loads((ctx.run_dir / POSEGRAPH_JSON).read_text(encoding="utf-8"))
            info = {k: GraphInfo(**v) for k, v in graphs.items()}
            notes = [str(n) for n in ate_data["notes"]]
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
            raise StorageError(f"{ctx.run_dir}: unreadable pose-graph results ({type(err).__name__}: {err})") from None
        return PoseGraphOutput(AteTable.from_json(ate_data, str(ctx.run_dir / ATE_JSON)), info, notes,
                               [f for f in files if f not in (ATE_JSON, POSEGRAPH_JSON)])
