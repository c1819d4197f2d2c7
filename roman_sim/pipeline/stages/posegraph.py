"""Stage ``posegraph``: the run's pose graphs and the trajectory variants they give.

The trajectory variants, in table order:

- ``odometry``: the drifting odometry, each robot placed with its true initial pose;
- ``odometry_no_prior``: the odometry with no start pose (each robot aligned by its own fit,
  which does not depend on where the robot is placed: it is scored from the ``odometry``
  trajectories);
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

The stage returns estimates only: every variant's trajectories (the robots it placed) and
the truth, each graph's closures with their GNC weights, and what each graph used. The
``ate`` stage scores them (``roman_sim.evaluation.atetable``) and the report stage draws
them. ``save`` writes ``trajectories/<robot>.<variant>.tum`` (every placed robot of every
variant, and the truth), ``posegraph.json`` (closures used and robots placed per graph) and
``posegraph_estimates.json`` (the variants' descriptions, fits and trajectory sources, each
graph's closures and weights, and the stage's notes). Later stages get the trajectories
as read back from the TUM files, so ``roman-sim report --verify`` recomputes the ATE
table exactly.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import StorageError
from roman_sim.core.geometry import gravity_aligned
from roman_sim.core.jsontypes import JSON
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum, write_tum
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.scenario import VISUAL_METHODS
from roman_sim.pipeline.stages.base import Stage, Timings
from roman_sim.pipeline.stages.estimates import (
    ESTIMATES_JSON,
    ESTIMATES_SCHEMA,
    GraphInfo,
    Variant,
    variant_from_json,
    variant_json,
)
from roman_sim.pipeline.stages.evaluation import EvaluationOutput
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.posegraph import LoopClosure, build_and_solve, submap_nodes_from
from roman_sim.runner.taskrunner import TaskRunner

log = logging.getLogger(__name__)

POSEGRAPH_JSON = "posegraph.json"
#: Name of the true trajectories among the variants' trajectory files.
TRUTH = "truth"
ORACLE_ASSOCIATIONS = 1_000_000


def tum_path(variant: str, robot: str) -> str:
    """Relative path of a variant's trajectory of one robot (``truth`` for the true trajectory)."""
    return f"trajectories/{robot}.{variant}.tum"


@dataclass
class PoseGraphOutput:
    """Every variant's trajectories, the variants, per-graph information, notes.

    Attributes:
        trajectories: trajectory source (``truth``, ``odometry``, each graph) -> robot ->
            trajectory, the placed robots only, in scenario order.
        variants: variant name -> ``Variant``, in table order (empty when skipped).
        graphs: graph name -> what it used.
        notes: statements for the report.
        timings: each graph's solve time (``posegraph_s``).
    """

    trajectories: dict[str, dict[str, Trajectory]]
    variants: dict[str, Variant]
    graphs: dict[str, GraphInfo]
    notes: list[str] = field(default_factory=list)
    timings: Timings = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class PoseGraphInputs:
    """The submaps and the evaluation's alignments; the maps (odometry, truth) unless the run started from submaps."""

    submaps: Submaps
    evaluation: EvaluationOutput
    maps: Maps | None = None


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


def odometry_variants() -> dict[str, Variant]:
    """The two odometry rows: placed with the true start pose, and aligned robot by robot."""
    return {
        "odometry": Variant("odometry, each robot placed with its true start pose", "joint", "odometry"),
        "odometry_no_prior": Variant(
            "odometry without start poses, each robot aligned on its own", "per_robot", "odometry"
        ),
    }


def solve_graphs(
    ctx: RunContext, inputs: PoseGraphInputs, maps: Maps, method: str
) -> tuple[PoseGraphOutput, dict[str, float]]:
    """Solve every graph variant on the maps' odometry; the output and each graph's solve time (s)."""
    truth = {r: m.truth for r, m in maps.maps.items() if m.truth is not None}
    odom = {r: m.odometry for r, m in maps.maps.items()}
    placed = {r: odom[r].transformed(gravity_aligned(truth[r].T[0])) for r in truth}
    nodes = submap_nodes_from(inputs.submaps.all())
    nodes = {r: nodes.get(r, []) for r in maps.maps}
    out = PoseGraphOutput({TRUTH: truth, "odometry": placed}, odometry_variants(), {})
    seconds = {}
    for gv in graph_variants(ctx):
        closures = gv.closures(inputs.submaps, inputs.evaluation)
        cfg = ctx.scenario.posegraph
        if gv.association_thresh is not None:
            cfg = cfg.model_copy(update={"lc_association_thresh": gv.association_thresh})
        t0 = time.perf_counter()
        res = build_and_solve(odom, nodes, closures, cfg)
        seconds[gv.name] = time.perf_counter() - t0
        used = [w for w in res.closure_weights if w is not None]
        out.graphs[gv.name] = GraphInfo(len(closures), len(used), res.n_inliers, list(res.unconnected))
        out.trajectories[gv.name] = res.trajectories
        out.variants[gv.name] = Variant(gv.description, "joint", gv.name, closures, list(res.closure_weights))
        if res.unconnected:
            out.notes.append(
                f"{gv.name} pose graph: robot(s) {', '.join(res.unconnected)} never connected to the "
                f"first robot: placed {len(res.trajectories)} of {len(odom)} robots"
            )
        if not used:
            out.notes.append(f"{gv.name} pose graph: no loop closure accepted")
    return out, seconds


class PoseGraphStage(Stage[PoseGraphInputs, PoseGraphOutput]):
    """Solve the run's pose graphs (method, visual, combined, oracle); every variant's trajectories."""

    name = "posegraph"
    input_type = PoseGraphInputs
    format = "estimates/1"

    def config_parts(self, ctx: RunContext) -> list[JSON]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["posegraph"], sc["posegraph_method"], sc["evaluation"]]

    def run(self, ctx: RunContext, inputs: PoseGraphInputs, tasks: TaskRunner) -> PoseGraphOutput:
        method = ctx.scenario.posegraph_method
        if method is None:
            return PoseGraphOutput({}, {}, {}, ["pose graph skipped: no posegraph_method"])
        if inputs.maps is None:
            return PoseGraphOutput({}, {}, {}, ["pose graph skipped: no trajectories (run started from saved submaps)"])
        out, seconds = solve_graphs(ctx, inputs, inputs.maps, method)
        out.timings["posegraph_s"] = dict(seconds)
        return out

    def save(self, out: PoseGraphOutput, ctx: RunContext) -> list[str]:
        written = []
        for variant, per in out.trajectories.items():
            for robot, tr in per.items():
                write_tum(ctx.run_dir / tum_path(variant, robot), tr)
                written.append(tum_path(variant, robot))
        write_json(ctx.run_dir / POSEGRAPH_JSON, {k: vars(v) for k, v in out.graphs.items()})
        estimates = [variant_json(k, v) for k, v in out.variants.items()]
        write_json(
            ctx.run_dir / ESTIMATES_JSON, {"schema": ESTIMATES_SCHEMA, "notes": out.notes, "variants": estimates}
        )
        return [POSEGRAPH_JSON, ESTIMATES_JSON, *sorted(written)]

    def load(self, ctx: RunContext, files: list[str]) -> PoseGraphOutput:
        path = ctx.run_dir / ESTIMATES_JSON  # the file being read, named by the error
        try:
            est = json.loads(path.read_text(encoding="utf-8"))
            if est.get("schema") != ESTIMATES_SCHEMA:
                raise ValueError(f"schema {est.get('schema')!r}")
            path = ctx.run_dir / POSEGRAPH_JSON
            graphs = json.loads(path.read_text(encoding="utf-8"))
            info = {k: GraphInfo(**v) for k, v in graphs.items()}
            variants = dict(variant_from_json(v) for v in est["variants"])
            notes = [str(n) for n in est["notes"]]
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
            raise StorageError(f"{path}: unreadable pose-graph results ({type(err).__name__}: {err})") from None
        sources = list(dict.fromkeys([TRUTH] + [v.source for v in variants.values()])) if variants else []
        listed = set(files)
        trajectories = {
            src: {
                r.name: read_tum(ctx.run_dir / tum_path(src, r.name))
                for r in ctx.scenario.robots
                if tum_path(src, r.name) in listed
            }
            for src in sources
        }
        return PoseGraphOutput(trajectories, variants, info, notes)
