"""Stage ``ate``: the ATE table of the pose graph's trajectory variants, every row over the same robots.

The table is computed by ``roman_sim.evaluation.atetable.ate_table`` from the variants the
``posegraph`` stage returns, as read back from their TUM files (what ``roman-sim report
--verify`` recomputes it from). ``save`` writes ``ate.json``: the table and the notes of the
pose graphs it scores. A run without a pose graph gets an empty table.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from roman_sim.evaluation.atetable import AteTable, ate_table, read_ate, write_ate
from roman_sim.evaluation.variants import TRUTH
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.base import Stage, Timings
from roman_sim.pipeline.stages.posegraph import PoseGraphOutput
from roman_sim.runner.taskrunner import TaskRunner

ATE_JSON = "ate.json"


@dataclass
class AteOutput:
    """The ATE table and the notes of the pose graphs it scores."""

    ate: AteTable
    notes: list[str] = field(default_factory=list)
    timings: Timings = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class AteInputs:
    """The pose graph's trajectory variants."""

    posegraph: PoseGraphOutput


class AteStage(Stage[AteInputs, AteOutput]):
    """Score the pose graph's trajectory variants against the truth."""

    name = "ate"
    input_type = AteInputs

    def run(self, ctx: RunContext, inputs: AteInputs, tasks: TaskRunner) -> AteOutput:
        pg = inputs.posegraph
        table = ate_table(pg.trajectories[TRUTH], pg.variants, pg.trajectories) if pg.variants else AteTable()
        return AteOutput(table, list(pg.notes))

    def save(self, out: AteOutput, ctx: RunContext) -> list[str]:
        write_ate(ctx.run_dir / ATE_JSON, out.ate, out.notes)
        return [ATE_JSON]

    def load(self, ctx: RunContext, files: list[str]) -> AteOutput:
        table, notes = read_ate(ctx.run_dir / ATE_JSON)
        return AteOutput(table, notes)
