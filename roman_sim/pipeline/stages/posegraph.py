"""Stage ``posegraph``: solve the run's pose graphs; every trajectory variant's trajectories.

Which variants exist and what closures each graph gets is ``roman_sim.evaluation.variants``
(the evaluation protocol); this stage feeds it the maps' odometry and truth, the submaps and
the evaluation's alignments and truths. ``save`` writes ``trajectories/<robot>.<variant>.tum``
(every placed robot of every variant, and the truth), ``posegraph.json`` (closures used and
robots placed per graph) and ``posegraph_estimates.json`` (the variants' descriptions, fits
and trajectory sources, each graph's closures and weights, and the stage's notes). Later
stages get the trajectories as read back from the TUM files, so ``roman-sim report
--verify`` recomputes the ATE table exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import read_record, write_record
from roman_sim.core.tum import read_tum, write_tum
from roman_sim.evaluation.variants import (
    TRUTH,
    GraphInfo,
    TrajectoryEstimates,
    VariantRow,
    graph_variants,
    solve_variants,
    variant_of_row,
    variant_row,
)
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.scenario import VISUAL_METHODS
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.evaluation import EvaluationOutput
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.runner.taskrunner import TaskRunner

POSEGRAPH_JSON = "posegraph.json"
ESTIMATES_JSON = "posegraph_estimates.json"


@dataclass
class EstimatesRecord:
    """What ``posegraph_estimates.json`` holds: the stage's notes and every variant (``variant_row``)."""

    notes: list[str]
    variants: list[VariantRow]


ESTIMATES_SCHEMA = "roman_sim.posegraph_estimates/1"
#: The stage's output: every variant with its trajectories.
PoseGraphOutput = TrajectoryEstimates


def tum_path(variant: str, robot: str) -> str:
    """Relative path of a variant's trajectory of one robot (``truth`` for the true trajectory)."""
    return f"trajectories/{robot}.{variant}.tum"


@dataclass(frozen=True)
class PoseGraphInputs:
    """The submaps and the evaluation's alignments; the maps (odometry, truth) unless the run started from submaps."""

    submaps: Submaps
    evaluation: EvaluationOutput
    maps: Maps | None = None


class PoseGraphStage(Stage[PoseGraphInputs, PoseGraphOutput]):
    """Solve the run's pose graphs (method, visual, combined, oracle); every variant's trajectories."""

    name = "posegraph"
    input_type = PoseGraphInputs
    format = "estimates/1"

    def config_parts(self, ctx: RunContext) -> list[JSON]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["posegraph"], sc["posegraph_method"], sc["evaluation"]]

    def run(self, ctx: RunContext, inputs: PoseGraphInputs, tasks: TaskRunner) -> PoseGraphOutput:
        sc = ctx.scenario
        method = sc.posegraph_method
        if method is None:
            return PoseGraphOutput({}, {}, {}, ["pose graph skipped: no posegraph_method"])
        if inputs.maps is None:
            return PoseGraphOutput({}, {}, {}, ["pose graph skipped: no trajectories (run started from saved submaps)"])
        maps, submaps = inputs.maps.maps, inputs.submaps.all()
        visual = next((a.name for a in sc.aligners if a.method in VISUAL_METHODS), None)
        ev = inputs.evaluation
        graphs = graph_variants(method, visual, sc.posegraph.lc_association_thresh, submaps, ev.alignments, ev.truths())
        truth = {r: m.truth for r, m in maps.items() if m.truth is not None}
        return solve_variants({r: m.odometry for r, m in maps.items()}, truth, submaps, graphs, sc.posegraph)

    def save(self, out: PoseGraphOutput, ctx: RunContext) -> list[str]:
        written = []
        for variant, per in out.trajectories.items():
            for robot, tr in per.items():
                write_tum(ctx.run_dir / tum_path(variant, robot), tr)
                written.append(tum_path(variant, robot))
        write_record(ctx.run_dir / POSEGRAPH_JSON, out.graphs)
        estimates = [variant_row(k, v) for k, v in out.variants.items()]
        write_record(ctx.run_dir / ESTIMATES_JSON, EstimatesRecord(out.notes, estimates), ESTIMATES_SCHEMA)
        return [POSEGRAPH_JSON, ESTIMATES_JSON, *sorted(written)]

    def load(self, ctx: RunContext, files: list[str]) -> PoseGraphOutput:
        est = read_record(ctx.run_dir / ESTIMATES_JSON, EstimatesRecord, ESTIMATES_SCHEMA)
        info = read_record(ctx.run_dir / POSEGRAPH_JSON, dict[str, GraphInfo])
        variants = dict(variant_of_row(v) for v in est.variants)
        notes = est.notes
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
