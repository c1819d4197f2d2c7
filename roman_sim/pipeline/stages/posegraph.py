"""Stage ``posegraph``: pose graphs of the run and their trajectory errors.

The trajectory variants scored against the truth, in table order:

- ``odometry``: the drifting odometry, each robot placed with its true initial pose;
- ``odometry_no_prior``: the odometry with no start pose (each robot aligned by its own fit,
  which does not depend on where the robot is placed: it is computed from the ``odometry``
  files);
- one row per entry of ``graph_variants``: the multi-robot pose graph with the chosen
  aligner's loop closures, and ``oracle``, the same graph with the true relative pose of
  every relevant pair (what loop closures can give at best). Adding a variant (e.g. a
  combined method) is one more ``GraphVariant`` in that list.

When the scenario also runs the visual method (and the pose graph's method is another
one), two more rows: ``<visual label>`` (the visual closures alone) and ``combined`` (the
method's and the visual closures in one GNC graph, as the paper's Table I combines ROMAN
with Kimera-Multi's visual loop closures). Visual closures are those the visual aligner
accepted (at least its ``min_inliers`` 3D-3D inliers); the method's keep
``lc_association_thresh``.

Every row of the ATE table covers the same robots (``roman_sim.evaluation.atetable``).
Writes ``ate.json`` (the table and the stage's notes), ``posegraph.json`` (closures used and
robots placed per graph), ``trajectories/<robot>.<variant>.tum`` (the placed robots of every
variant, and the truth) and ``plots/trajectories.png``. The table is computed from the TUM
files as written, so ``roman-sim report --verify`` recomputes it exactly.
"""

from __future__ import annotations

import json
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import EvaluationError, StorageError
from roman_sim.core.geometry import gravity_aligned, pose_error
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum, write_tum
from roman_sim.evaluation.ate import multi_robot_ate
from roman_sim.evaluation.atetable import AteTable, VariantEstimate, ate_table
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.scenario import VISUAL_METHODS
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.evaluation import EvaluationOutput
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.posegraph import LoopClosure, build_and_solve, submap_nodes_from
from roman_sim.report.trajplot import plot_trajectories

log = logging.getLogger(__name__)

ATE_JSON = "ate.json"
POSEGRAPH_JSON = "posegraph.json"
PLOT = "plots/trajectories.png"
ORACLE_ASSOCIATIONS = 1_000_000


def tum_path(variant: str, robot: str) -> str:
    """Relative path of a variant's trajectory of one robot (``truth`` for the true trajectory)."""
    return f"trajectories/{robot}.{variant}.tum"


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
    """ATE table, per-graph information, notes.

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
        out.append(
            LoopClosure(
                a.robot,
                a.index,
                b.robot,
                b.index,
                np.asarray(r.T_a_b, dtype=np.float64),
                n_associations=r.n_associations,
                source=method,
            )
        )
    return out


def oracle_closures(submaps: Submaps, evaluation: EvaluationOutput) -> list[LoopClosure]:
    """True relative poses of every relevant pair."""
    subs = submaps.by_name()
    out = []
    for (a_name, b_name), t in sorted(evaluation.truths().items()):
        if t.relevant:
            a, b = subs[a_name], subs[b_name]
            out.append(
                LoopClosure(
                    a.robot,
                    a.index,
                    b.robot,
                    b.index,
                    np.asarray(t.T_a_b_true),
                    n_associations=ORACLE_ASSOCIATIONS,
                    source="oracle",
                )
            )
    return out


@dataclass(frozen=True)
class GraphVariant:
    """A pose-graph row of the ATE table: its name, what it is, where its closures come from.

    ``association_thresh`` overrides the scenario's ``lc_association_thresh`` for this graph
    (None keeps it; visual closures are already verified, so their graphs use 0).
    """

    name: str
    description: str
    closures: Callable[[Submaps, EvaluationOutput], list[LoopClosure]]
    association_thresh: int | None = None


def graph_variants(ctx: RunContext) -> list[GraphVariant]:
    """The pose graphs of a run, in table order (one entry per variant)."""
    method = ctx.scenario.posegraph_method
    assert method is not None
    thresh = ctx.scenario.posegraph.lc_association_thresh
    out = [
        GraphVariant(method, f"pose graph with {method}'s loop closures", lambda s, e: method_closures(s, e, method))
    ]
    visual = next((a.name for a in ctx.scenario.aligners if a.method in VISUAL_METHODS), None)
    if visual is not None and visual != method:
        vis = visual

        def combined(s: Submaps, e: EvaluationOutput) -> list[LoopClosure]:
            own = [c for c in method_closures(s, e, method) if c.n_associations >= thresh]
            return own + method_closures(s, e, vis)

        out += [
            GraphVariant(
                vis, f"pose graph with {vis}'s visual loop closures", lambda s, e: method_closures(s, e, vis), 0
            ),
            GraphVariant("combined", f"pose graph with {method}'s and {vis}'s loop closures", combined, 0),
        ]
    out.append(GraphVariant("oracle", "pose graph with the true relative pose of every relevant pair", oracle_closures))
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


def _round_trip(ctx: RunContext, trajectories: dict[str, dict[str, Trajectory]]) -> tuple[dict, list[str]]:
    """Write every variant's trajectories as TUM and read them back (what the table is computed from)."""
    back: dict[str, dict[str, Trajectory]] = {}
    written = []
    for variant, per in trajectories.items():
        back[variant] = {}
        for robot, tr in per.items():
            path = tum_path(variant, robot)
            write_tum(ctx.run_dir / path, tr)
            back[variant][robot] = read_tum(ctx.run_dir / path)
            written.append(path)
    return back, written


class PoseGraphStage(Stage[PoseGraphOutput]):
    """Solve the run's pose graphs (method, visual, combined, oracle) and score every variant over the same robots."""

    name = "posegraph"
    inputs = ("maps", "submaps", "evaluation")

    def config_parts(self, ctx: RunContext) -> list[Any]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["posegraph"], sc["posegraph_method"], sc["evaluation"]]

    def run(
        self,
        ctx: RunContext,
        maps: Maps | None = None,
        submaps: Submaps | None = None,
        evaluation: EvaluationOutput | None = None,
        **_: Any,
    ) -> PoseGraphOutput:
        assert submaps is not None and evaluation is not None
        method = ctx.scenario.posegraph_method
        if method is None:
            return PoseGraphOutput(AteTable(), {}, ["pose graph skipped: no posegraph_method"])
        if maps is None:
            return PoseGraphOutput(
                AteTable(), {}, ["pose graph skipped: no trajectories (run started from saved submaps)"]
            )
        truth = {r: m.truth for r, m in maps.maps.items() if m.truth is not None}
        odom = {r: m.odometry for r, m in maps.maps.items()}
        placed = {r: odom[r].transformed(gravity_aligned(truth[r].T[0])) for r in truth}
        nodes = submap_nodes_from(submaps.all())
        nodes = {r: nodes.get(r, []) for r in maps.maps}
        trajectories: dict[str, dict[str, Trajectory]] = {"truth": truth, "odometry": placed}
        describe = {
            "odometry": ("odometry, each robot placed with its true start pose", "joint", "odometry"),
            "odometry_no_prior": (
                "odometry without start poses, each robot aligned on its own",
                "per_robot",
                "odometry",
            ),
        }
        graphs, notes, seconds = {}, [], {}
        lines, est_world = [], {}
        for gv in graph_variants(ctx):
            closures = gv.closures(submaps, evaluation)
            cfg = ctx.scenario.posegraph
            if gv.association_thresh is not None:
                cfg = cfg.model_copy(update={"lc_association_thresh": gv.association_thresh})
            t0 = time.perf_counter()
            res = build_and_solve(odom, nodes, closures, cfg)
            seconds[gv.name] = time.perf_counter() - t0
            used = [w for w in res.closure_weights if w is not None]
            graphs[gv.name] = GraphInfo(len(closures), len(used), res.n_inliers, list(res.unconnected))
            trajectories[gv.name] = res.trajectories
            describe[gv.name] = (gv.description, "joint", gv.name)
            if res.unconnected:
                notes.append(
                    f"{gv.name} pose graph: robot(s) {', '.join(res.unconnected)} never connected to the "
                    f"first robot: placed {len(res.trajectories)} of {len(odom)} robots"
                )
            if not used:
                notes.append(f"{gv.name} pose graph: no loop closure accepted")
            if gv.name == method:
                lines = _closure_lines(ctx, submaps, closures, res.closure_weights)
                est_world = _aligned(res.trajectories, truth)
        ctx.timings["posegraph_s"] = seconds
        back, written = _round_trip(ctx, trajectories)
        estimates = {
            v: VariantEstimate(back[src], fit, text, src)  # type: ignore[arg-type]
            for v, (text, fit, src) in describe.items()
        }
        table = ate_table(back["truth"], estimates)
        try:
            plot_trajectories(
                ctx.run_dir / PLOT,
                truth,
                est=est_world or None,
                odom=placed,
                closures=lines,
                title=f"{ctx.scenario.name}: truth, odometry and {method} pose graph",
            )
            written.append(PLOT)
        except EvaluationError as err:
            notes.append(f"trajectory plot not drawn: {err}")
        return PoseGraphOutput(table, graphs, notes, sorted(written))

    def save(self, out: PoseGraphOutput, ctx: RunContext) -> list[str]:
        write_json(ctx.run_dir / ATE_JSON, {**out.ate.to_json(), "notes": out.notes})
        write_json(ctx.run_dir / POSEGRAPH_JSON, {k: vars(v) for k, v in out.graphs.items()})
        return [ATE_JSON, POSEGRAPH_JSON, *out.written]

    def load(self, ctx: RunContext, files: list[str]) -> PoseGraphOutput:
        path = ctx.run_dir / ATE_JSON  # the file being read, named by the error
        try:
            ate_data = json.loads(path.read_text(encoding="utf-8"))
            notes = [str(n) for n in ate_data["notes"]]
            path = ctx.run_dir / POSEGRAPH_JSON
            graphs = json.loads(path.read_text(encoding="utf-8"))
            info = {k: GraphInfo(**v) for k, v in graphs.items()}
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
            raise StorageError(f"{path}: unreadable pose-graph results ({type(err).__name__}: {err})") from None
        return PoseGraphOutput(
            AteTable.from_json(ate_data, str(ctx.run_dir / ATE_JSON)),
            info,
            notes,
            [f for f in files if f not in (ATE_JSON, POSEGRAPH_JSON)],
        )
