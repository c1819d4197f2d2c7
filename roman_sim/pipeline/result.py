"""``RunResult``: what a run produced, from the run itself or opened from any finished run folder."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar, cast

from roman_sim.core.errors import StorageError
from roman_sim.core.records import to_json
from roman_sim.evaluation.records import RunTimings
from roman_sim.evaluation.records import read_timings as read_run_timings
from roman_sim.evaluation.run_summary import RunSummary, summarize_run
from roman_sim.evaluation.types import AteTable, EvaluationMetrics, MapStats
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.manifest import changed_files, read_manifest
from roman_sim.pipeline.scenario import Scenario, load_scenario
from roman_sim.pipeline.stages import STAGES, AteOutput, EvaluationOutput, ReportOutput, StageOutput
from roman_sim.pipeline.stages.base import Timings

log = logging.getLogger(__name__)

TIMINGS_JSON = "timings.json"
#: The stages whose outputs a result is made of.
RESULT_STAGES = ("evaluation", "ate", "report")

OutT = TypeVar("OutT")


def _output(outputs: Mapping[str, StageOutput], name: str, kind: type[OutT]) -> OutT:
    out = outputs.get(name)
    if not isinstance(out, kind):
        raise StorageError(f"the run has no {name} output (stage missing or of another kind)")
    return out


@dataclass
class RunResult:
    """The results of one run (everything is also on disk in ``run_dir``).

    Attributes:
        run_dir: the run folder.
        scenario: the resolved scenario.
        metrics: the alignment evaluation.
        ate: ATE RMSE per pose-graph variant (empty when no pose graph was solved).
        map_stats: map and packet sizes.
        notes: every stage's statements for the report, in stage order.
        timings: wall-clock figures per stage (``timings.json``; empty when a folder has none).
        reused: stages whose cached outputs were reused.
    """

    run_dir: Path
    scenario: Scenario
    metrics: EvaluationMetrics
    ate: AteTable
    map_stats: MapStats
    notes: list[str] = field(default_factory=list)
    timings: RunTimings = field(default_factory=RunTimings)
    reused: list[str] = field(default_factory=list)

    @classmethod
    def from_outputs(
        cls,
        run_dir: Path,
        scenario: Scenario,
        outputs: Mapping[str, StageOutput],
        timings: RunTimings,
        reused: list[str],
    ) -> "RunResult":
        """The result of a run from its stage outputs (those of ``RESULT_STAGES``)."""
        ev = _output(outputs, "evaluation", EvaluationOutput)
        ate = _output(outputs, "ate", AteOutput)
        rep = _output(outputs, "report", ReportOutput)
        return cls(run_dir, scenario, ev.metrics, ate.ate, rep.map_stats, list(rep.notes), timings, reused)

    @classmethod
    def load(cls, run_dir: str | Path) -> "RunResult":
        """Open a finished run folder.

        Raises:
            StorageError: not a run folder, a run that did not complete (naming the missing
                stages), a folder of an older stage table, a configuration that does not match
                the outputs, or unreadable files.

        A file whose bytes differ from the SHA-256 ``manifest.json`` recorded for it (edited after
        the run) is named in a warning.
        """
        d = Path(run_dir)
        man = read_manifest(d)
        if not man.complete:
            raise StorageError(
                f"{d}: the run did not complete (stages missing: {', '.join(man.missing)}); run it again to finish it"
            )
        if not (d / "config.yaml").is_file():
            raise StorageError(
                f"{d}: the run's config.yaml is missing (deleted after the run?); "
                "run the scenario into this folder again to rewrite it"
            )
        sc = load_scenario(d / "config.yaml")
        if sc.config_hash() != man.config_hash:
            raise StorageError(f"{d}: config.yaml does not match the run's outputs (edited after the run?)")
        never = [s for s in RESULT_STAGES if s not in man.stages]
        if never:
            raise StorageError(
                f"{d}: written by an older version without the {', '.join(never)} stage(s); run it again to update it"
            )
        for line in changed_files(d, man):
            log.warning("%s: the figures read from it are not the run's", line)
        ctx = RunContext(sc, d)
        outputs = {
            s.name: s.load(ctx, man.stages[s.name].files)
            for s in STAGES
            if s.name in man.stages and s.name in RESULT_STAGES
        }
        timings = read_run_timings(d / TIMINGS_JSON) if (d / TIMINGS_JSON).is_file() else RunTimings()
        return cls.from_outputs(d, sc, outputs, timings, [])

    def recall(self, method: str, heading_bin: str | None = None, kind: str | None = None) -> float | None:
        """Max recall of ``method`` overall or in a heading bin such as ``"120-180"``.

        ``kind``: ``inter`` (cross-robot) or ``intra`` (same-robot); default the
        headline set (cross-robot when the run has cross-robot pairs).
        """
        return self.metrics.figure(method, heading_bin, "max_recall", kind)

    def runtime_median_s(self, method: str) -> float | None:
        """Median alignment time per pair of ``method`` (s), from the timings; None if unknown."""
        return self.timings.median_s(method)

    def summary(self) -> RunSummary:
        """The run in short (per method recall, runtime; ATE; map size): ``summarize_run``."""
        runtimes = {m: self.runtime_median_s(m) for m in self.metrics.methods}
        return summarize_run(self.metrics, self.ate, self.map_stats, runtimes)


def read_timings(run_dir: Path) -> dict[str, Timings]:
    """The per-stage timings of a run folder, as JSON figures (empty when it has no ``timings.json``).

    Raises:
        RecordError: the file is there but is not a timings record (names the file and the field).
    """
    path = run_dir / TIMINGS_JSON
    if not path.is_file():
        return {}
    return cast(dict[str, Timings], to_json(read_run_timings(path).stages))


__all__ = ["TIMINGS_JSON", "RunResult", "read_timings"]
