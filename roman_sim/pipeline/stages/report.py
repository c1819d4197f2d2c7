"""Stage ``report``: map statistics, the plots and ``report.md`` from the other stages' outputs.

Draws the metric plots (from the metrics), each method's example alignments (from the
recorded estimates and associations over the submaps), the map view and a front-end
snapshot: ``plots/segments_on_image.png`` renders one camera image of the first robot, at
the centre of its submap with the most segments, runs the scenario's segmenter on it and
draws the masks over it. A plot that cannot be drawn (no OpenGL context, no world when the
run started from saved submaps, a single point) is noted and skipped.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import EvaluationError, RomanSimError, StorageError
from roman_sim.evaluation.types import MapStats
from roman_sim.mapping.frontend import reads_truth
from roman_sim.mapping.io import packet_bytes
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.robot_mapping import build_segmenter_for
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.evaluation import EvaluationOutput
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.posegraph import PoseGraphOutput
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.pipeline.stages.world import WorldOutput
from roman_sim.report.examples import draw_examples
from roman_sim.report.mapview import write_map_view
from roman_sim.report.markdown import REPORT_MD, write_report
from roman_sim.report.maskview import plot_masks
from roman_sim.report.plots import write_metric_plots

MAP_STATS_JSON = "map_stats.json"
SNAPSHOT = "plots/segments_on_image.png"


@dataclass
class ReportOutput:
    """Map statistics and every note of the run, in stage order."""

    map_stats: MapStats
    notes: list[str] = field(default_factory=list)
    written: list[str] = field(default_factory=list, repr=False)


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


def _majority(object_ids: np.ndarray, pixels: np.ndarray) -> str | None:
    """The most frequent true object id under a mask (None when it covers only terrain/sky)."""
    ids = object_ids[pixels]
    ids = ids[ids >= 0]
    return None if not len(ids) else str(int(np.bincount(ids).argmax()))


def snapshot(ctx: RunContext, world: WorldOutput, maps: Maps, submaps: Submaps) -> str:
    """Render one frame of the first robot, segment it, draw the masks; the plot's relative path.

    The segmenter sees the frame without truth unless it reads truth (as in the maps stage);
    the numbers drawn are each mask's majority true object, from the object-id render.

    Raises:
        RomanSimError: the frame cannot be rendered or segmented (no OpenGL, ...).
    """
    from roman_sim.sim.robot import DrivenRun, render_trajectory

    cfg = ctx.scenario.robots[0]
    smap, subs = maps.maps[cfg.name], submaps.submaps.get(cfg.name) or []
    if smap.T_world_body is None or not len(smap.times):
        raise StorageError(f"robot {cfg.name} has no true trajectory to render from")
    t = max(subs, key=lambda s: (len(s), -s.index)).t if subs else float(smap.times[len(smap.times) // 2])
    i = int(np.argmin(np.abs(smap.times - t)))
    run = DrivenRun(smap.times[i : i + 1], smap.T_world_body[i : i + 1], smap.T_odom_body[i : i + 1])
    frame = next(
        iter(render_trajectory(world.world, cfg.model_copy(update={"render_rgb": True}), ctx.scenario.seed, run))
    )
    if frame.rgb is None:
        raise StorageError(f"robot {cfg.name}: the renderer gave no colour image")
    segmenter = build_segmenter_for(ctx, cfg.name)
    masks = segmenter.segment(frame if reads_truth(segmenter) else frame.public())
    ids = frame.truth.object_ids if frame.truth is not None else None
    labels = [None if ids is None else _majority(ids, m.pixels) for m in masks]
    seg = ctx.scenario.frontend.segmenter
    title = (
        f"robot {cfg.name} at t = {frame.t:.1f} s: {len(masks)} masks of the "
        f"{seg if isinstance(seg, str) else 'configured'} segmenter (numbers: majority true object)"
    )
    plot_masks(frame.rgb, [m.pixels for m in masks], ctx.run_dir / SNAPSHOT, title, labels)
    return SNAPSHOT


def draw_plots(ctx: RunContext, evaluation: EvaluationOutput, submaps: Submaps) -> tuple[list[str], list[str]]:
    """Metric plots, example alignments and the map view: (relative paths written, notes)."""
    plots = ctx.run_dir / "plots"
    written, notes = write_metric_plots(evaluation.metrics, plots)
    results = {(r.a, r.b, r.method): r.result() for r in evaluation.alignments}
    written += draw_examples(evaluation.scores, submaps.by_name(), results, plots)
    try:
        written.append(write_map_view(plots / "map_view.png", submaps.all()))
    except EvaluationError as err:
        notes.append(f"map view not rendered: {err}")
    return [p.relative_to(ctx.run_dir).as_posix() for p in written], notes


class ReportStage(Stage[ReportOutput]):
    """Write ``map_stats.json``, the front-end snapshot and ``report.md``."""

    name = "report"
    inputs = ("world", "maps", "submaps", "evaluation", "posegraph")

    def run(
        self,
        ctx: RunContext,
        world: WorldOutput | None = None,
        maps: Maps | None = None,
        submaps: Submaps | None = None,
        evaluation: EvaluationOutput | None = None,
        posegraph: PoseGraphOutput | None = None,
        **_: Any,
    ) -> ReportOutput:
        assert submaps is not None and evaluation is not None and posegraph is not None
        notes: list[str] = []
        for out in (maps, submaps, evaluation, posegraph):
            notes += [] if out is None else list(out.notes)
        stats = map_stats(maps, submaps)
        snap, plot_notes = draw_plots(ctx, evaluation, submaps)
        notes += plot_notes
        plots = [f for f in (maps.written if maps else []) + posegraph.written if f.endswith(".png")]
        if world is not None and maps is not None:
            try:
                snap.append(snapshot(ctx, world, maps, submaps))
            except (RomanSimError, RuntimeError, ImportError) as err:
                notes.append(f"front-end snapshot not drawn: {err}")
        plots += snap
        ate = posegraph.ate if posegraph.ate.variants else None
        write_report(ctx.run_dir, ctx.scenario.name, evaluation.metrics, ate, stats, list(dict.fromkeys(notes)), plots)
        return ReportOutput(stats, list(dict.fromkeys(notes)), snap)

    def save(self, out: ReportOutput, ctx: RunContext) -> list[str]:
        write_json(ctx.run_dir / MAP_STATS_JSON, {**out.map_stats.to_json(), "notes": out.notes})
        return [MAP_STATS_JSON, REPORT_MD, *out.written]

    def load(self, ctx: RunContext, files: list[str]) -> ReportOutput:
        path = ctx.run_dir / MAP_STATS_JSON
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            notes = [str(n) for n in data.pop("notes")]
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
            raise StorageError(f"{path}: unreadable ({type(err).__name__}: {err})") from None
        return ReportOutput(MapStats.from_json(data, str(path)), notes, [f for f in files if f.endswith(".png")])
