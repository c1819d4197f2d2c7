"""Stage ``report``: map statistics and ``report.md`` from the outputs of every other stage."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import StorageError
from roman_sim.evaluation.report import REPORT_MD, write_report
from roman_sim.evaluation.types import MapStats
from roman_sim.mapping.io import packet_bytes
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.evaluation import EvaluationOutput
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.posegraph import PoseGraphOutput
from roman_sim.pipeline.stages.submaps import Submaps

MAP_STATS_JSON = "map_stats.json"


@dataclass
class ReportOutput:
    """Map statistics and every note of the run, in stage order."""

    map_stats: MapStats
    notes: list[str] = field(default_factory=list)


def map_stats(maps: Maps | None, submaps: Submaps) -> MapStats:
    """Segments, submaps, packet size per submap and MB per km of trajectory (keyframes apart)."""
    subs = submaps.all()
    sizes = [packet_bytes(s) for s in subs]
    length_m = sum(m.trajectory_length_m for m in maps.maps.values()) if maps else 0.0
    with_kf = [s for s in subs if s.keyframes is not None]
    kf = [packet_bytes(s, "keyframes") for s in with_kf]
    return MapStats(
        keyframes_per_submap=float(np.mean([len(s.keyframes or []) for s in with_kf])) if with_kf else None,
        keyframe_kb_per_submap=float(np.mean(kf)) / 1000.0 if kf else None,
        keyframe_kb_per_submap_max=float(np.max(kf)) / 1000.0 if kf else None,
        keyframe_mb_per_km=(sum(kf) / 1e6) / (length_m / 1000.0) if kf and length_m > 0 else None,
        robots=len(submaps.submaps),
        segments=sum(len(m) for m in maps.maps.values()) if maps else None,
        submaps=len(subs),
        segments_per_submap=float(np.mean([len(s) for s in subs])) if subs else None,
        kb_per_submap=float(np.mean(sizes)) / 1000.0 if sizes else None,
        kb_per_submap_max=float(np.max(sizes)) / 1000.0 if sizes else None,
        trajectory_km=length_m / 1000.0 if maps else None,
        mb_per_km=(sum(sizes) / 1e6) / (length_m / 1000.0) if maps and length_m > 0 else None,
    )


class ReportStage(Stage[ReportOutput]):
    """Write ``map_stats.json`` and ``report.md``."""

    name = "report"
    inputs = ("maps", "submaps", "evaluation", "posegraph")

    def run(self, ctx: RunContext, maps: Maps | None = None, submaps: Submaps | None = None,
            evaluation: EvaluationOutput | None = None, posegraph: PoseGraphOutput | None = None,
            **_: Any) -> ReportOutput:
        assert submaps is not None and evaluation is not None and posegraph is not None
        notes: list[str] = []
        for out in (maps, submaps, evaluation, posegraph):
            notes += [] if out is None else list(out.notes)
        stats = map_stats(maps, submaps)
        written = (maps.written if maps else []) + evaluation.written + posegraph.written
        plots = [f for f in written if f.endswith(".png")]
        write_report(ctx.run_dir, ctx.scenario.name, evaluation.metrics, posegraph.ate if posegraph.ate.variants else None,
                     stats, list(dict.fromkeys(notes)), plots)
        return ReportOutput(stats, list(dict.fromkeys(notes)))

    def save(self, out: ReportOutput, ctx: RunContext) -> list[str]:
        write_json(ctx.run_dir / MAP_STATS_JSON, {**out.map_stats.to_json(), "notes": out.notes})
        return [MAP_STATS_JSON, REPORT_MD]

    def load(self, ctx: RunContext, files: list[str]) -> ReportOutput:
        path = ctx.run_dir / MAP_STATS_JSON
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            notes = [str(n) for n in data.pop("notes")]
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
            raise StorageError(f"{path}: unreadable ({type(err).__name__}: {err})") from None
        return ReportOutput(MapStats.from_json(data, str(path)), notes)
