"""Stage ``report``: map statistics, the plots and ``report.md`` from the other stages' outputs.

``run`` computes everything the report shows: the map statistics, the front end's grades
(from the maps stage), the metric plots (from the metrics), each method's example
alignments (from the recorded estimates and associations over the submaps), the map view,
the trajectory plot (truth, odometry and the pose graph method's estimate moved onto the
truth, with the closures that graph used) and the front-end snapshot
(``plots/segments_on_image.png``: the camera image and masks the maps stage kept). Every
figure is drawn by ``roman_sim.report`` from saved outputs; nothing is rendered or
segmented here. Plots are rendered to bytes, each a PNG with a vector PDF beside it
(``plots/x.png`` and ``plots/x.pdf``; ``roman_sim.core.figures``), and the report to text
(it shows the PNGs); ``save`` writes them with ``map_stats.json``. A plot that cannot be
drawn (no snapshot kept, a single point) is noted and skipped. The report depends on the
scenario's name (its title), so a renamed scenario rewrites it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import PurePosixPath

from roman_sim.core.atomic import write_bytes, write_text
from roman_sim.core.errors import EvaluationError
from roman_sim.core.figures import PNG
from roman_sim.core.jsontypes import JSON
from roman_sim.evaluation.ate import aligned_to_truth
from roman_sim.evaluation.records import MapStats, map_stats, read_map_stats, write_map_stats
from roman_sim.evaluation.variants import TRUTH
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.ate import AteOutput
from roman_sim.pipeline.stages.base import Stage, Timings
from roman_sim.pipeline.stages.evaluation import EvaluationOutput
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.pipeline.stages.posegraph import PoseGraphOutput
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.report.examples import ExampleRule, example_file, example_rows
from roman_sim.report.markdown import REPORT_MD, report_markdown
from roman_sim.report.plots import METRIC_PLOTS
from roman_sim.report.render import (
    Drawn,
    draw_job,
    frontend_grades_png,
    map_view_job,
    method_examples_png,
    metric_plot_png,
    trajectory_plot_png,
)
from roman_sim.report.snapshot import snapshot_job
from roman_sim.report.trajplot import closure_lines
from roman_sim.runner.taskrunner import TaskRunner

MAP_STATS_JSON = "map_stats.json"
FRONTEND_PNG = "plots/frontend.png"
SNAPSHOT = "plots/segments_on_image.png"
TRAJECTORY_PLOT = "plots/trajectories.png"
MAP_VIEW = "plots/map_view.png"


@dataclass
class ReportOutput:
    """Map statistics and every note of the run, in stage order.

    ``text`` (``report.md``) and ``plots`` (relative path -> bytes: each figure's PNG and its
    PDF) are what ``save`` writes; a loaded output has neither (nothing downstream reads
    them), ``written`` lists the figures' PNGs either way.
    """

    map_stats: MapStats
    notes: list[str] = field(default_factory=list)
    text: str = field(default="", repr=False)
    plots: dict[str, bytes] = field(default_factory=dict, repr=False)
    written: list[str] = field(default_factory=list, repr=False)
    timings: Timings = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class ReportInputs:
    """Every earlier stage's output (maps: None when the run started from saved submaps)."""

    submaps: Submaps
    evaluation: EvaluationOutput
    posegraph: PoseGraphOutput
    ate: AteOutput
    maps: Maps | None = None


def trajectory_plot(ctx: RunContext, posegraph: PoseGraphOutput, submaps: Submaps) -> PlotJob | None:
    """Truth, placed odometry and the method's pose graph moved onto the truth, with the closures it used.

    The drawing job (``render.trajectory_plot_png``); None when no pose graph was solved.
    Raises EvaluationError when there is nothing to draw.
    """
    method = ctx.scenario.posegraph_method
    if method is None or method not in posegraph.variants:
        return None
    truth = posegraph.trajectories[TRUTH]
    graph = posegraph.variants[method]
    ev, thresh = ctx.scenario.evaluation, ctx.scenario.posegraph.lc_association_thresh
    lines = closure_lines(graph.closures, graph.weights, submaps.by_name(), thresh, ev.rot_tol_deg, ev.trans_tol_m)
    est = aligned_to_truth(posegraph.trajectories[graph.source], truth) or None
    title = f"{ctx.scenario.name}: truth, odometry and {method} pose graph"
    args = (truth, est, posegraph.trajectories["odometry"], lines, title)
    return PlotJob(TRAJECTORY_PLOT, trajectory_plot_png, args)


@dataclass(frozen=True)
class PlotJob:
    """One figure, ``name``: ``fn(*args)`` draws it (``roman_sim.report.render.Drawn``); ``here``: in this process."""

    name: str
    fn: Callable[..., Drawn]
    args: tuple[object, ...]
    here: bool = False


def plot_jobs(ctx: RunContext, inputs: ReportInputs) -> list[PlotJob]:
    """Every figure of the report, in report order: the front end's grades, metric plots, example alignments,
    the map view, the trajectories and the front-end snapshot (those the run has what they need for)."""
    ev, submaps, maps = inputs.evaluation, inputs.submaps, inputs.maps
    results = {(r.a, r.b, r.method): r.result() for r in ev.alignments}
    jobs = [PlotJob(FRONTEND_PNG, frontend_grades_png, (maps.frontend,))] if maps and maps.frontend else []
    jobs += [PlotJob(f"plots/{name}", metric_plot_png, (ev.metrics, name)) for name in METRIC_PLOTS]
    cfg = ctx.scenario.evaluation
    rule = ExampleRule(ev.metrics.acceptance_k or 1, cfg.rot_tol_deg, cfg.trans_tol_m)
    examples = example_rows(ev.scores, submaps.by_name(), results, rule)
    for method in sorted({*ev.metrics.methods, *examples}):
        name = f"plots/{example_file(method)}"
        if method in examples:
            title, rows = examples[method]
            jobs.append(PlotJob(name, method_examples_png, (method, rows, title)))
        else:
            why = f"{method} has no correct relevant pair and no wrong estimate with >= {rule.min_assoc} associations"
            jobs.append(PlotJob(name, _noted, (f"plot {example_file(method)} not drawn: {why}",), here=True))
    jobs.append(PlotJob(MAP_VIEW, map_view_job, (submaps.all(), ctx.scenario.name)))
    try:
        traj = trajectory_plot(ctx, inputs.posegraph, submaps)
        if traj is not None:
            jobs.append(traj)
        else:
            pg = ctx.scenario.posegraph_method
            why = "the scenario names no posegraph_method" if pg is None else f"no {pg} pose graph was solved"
            jobs.append(PlotJob(TRAJECTORY_PLOT, _noted, (f"plot trajectories.png not drawn: {why}",), here=True))
    except EvaluationError as err:
        jobs.append(PlotJob(TRAJECTORY_PLOT, _noted, (f"plot trajectories.png not drawn: {err}",), here=True))
    if maps is not None and maps.snapshot is not None:
        jobs.append(PlotJob(SNAPSHOT, snapshot_job, (maps.snapshot,)))
    elif maps is not None:
        jobs.append(
            PlotJob(
                SNAPSHOT,
                _noted,
                ("plot segments_on_image.png not drawn: the maps stage kept no camera frame",),
                here=True,
            )
        )
    return jobs


def _noted(note: str) -> Drawn:
    return None, [note]


def draw_plots(
    ctx: RunContext, inputs: ReportInputs, tasks: TaskRunner | None = None
) -> tuple[dict[str, bytes], list[str]]:
    """Every figure of ``plot_jobs``: (path -> bytes of each figure's PNG and its PDF beside it, notes).

    With a local pool (``tasks``), its workers draw the figures, the largest first, while
    this process adds its notes once the first figure is back; otherwise everything is
    drawn here. Never on Dask workers: the bytes depend on the installed matplotlib and
    fonts, and those workers may run elsewhere. The
    figures and notes come out in report order wherever they were drawn.
    """
    jobs = plot_jobs(ctx, inputs)
    drawn: dict[int, Drawn] = {}
    here = [i for i, j in enumerate(jobs) if j.here or tasks is None or tasks.kind != "local"]
    there = sorted((i for i in range(len(jobs)) if i not in here), key=lambda i: -_weight(jobs[i]))
    if there:
        assert tasks is not None
        runs = tasks.run_unkept(
            draw_job, [(jobs[i].fn, *jobs[i].args) for i in there], [f"drawing {jobs[i].name}" for i in there]
        )
        for k, out in runs:
            drawn[there[k]] = out
            for i in here:  # this process's own figures, while the workers draw on
                drawn[i] = jobs[i].fn(*jobs[i].args)
            here = []
    for i in here:
        drawn[i] = jobs[i].fn(*jobs[i].args)
    files: dict[str, bytes] = {}
    notes: list[str] = []
    for i, job in enumerate(jobs):
        figure, more = drawn[i]
        for suffix, blob in (figure or {}).items():
            files[str(PurePosixPath(job.name).with_suffix(suffix))] = blob
        notes += more
    return files, notes


def _weight(job: PlotJob) -> int:
    """Rough drawing cost, to hand out the largest figures first (map view, example figures, the rest)."""
    return 3 if job.fn is map_view_job else 2 if job.fn is method_examples_png else 1


class ReportStage(Stage[ReportInputs, ReportOutput]):
    """Write ``map_stats.json``, the plots and ``report.md``."""

    name = "report"
    input_type = ReportInputs
    uses_workers = True
    worker_preload = ("roman_sim.report.render", "roman_sim.report.examples", "roman_sim.report.trajplot")

    def config_parts(self, ctx: RunContext) -> list[JSON]:
        # a run without figures keys its report apart; a run with them keeps the key it always had
        return [ctx.scenario.name] if ctx.figures else [ctx.scenario.name, "no figures"]

    def run(self, ctx: RunContext, inputs: ReportInputs, tasks: TaskRunner) -> ReportOutput:
        notes: list[str] = []
        for out in (inputs.maps, inputs.submaps, inputs.evaluation, inputs.posegraph, inputs.ate):
            notes += [] if out is None else list(out.notes)
        maps = inputs.maps.maps if inputs.maps else None
        stats = map_stats(
            inputs.submaps.all(),
            len(inputs.submaps.submaps),
            None if maps is None else sum(len(m) for m in maps.values()),
            None if maps is None else sum(m.trajectory_length_m for m in maps.values()),
        )
        files, plot_notes = draw_plots(ctx, inputs, tasks) if ctx.figures else ({}, ["figures not drawn"])
        pngs = [f for f in files if f.endswith(PNG)]
        notes = list(dict.fromkeys(notes + plot_notes))
        ate = inputs.ate.ate if inputs.ate.ate.variants else None
        text = report_markdown(ctx.scenario.name, inputs.evaluation.metrics, ate, stats, notes, pngs)
        return ReportOutput(stats, notes, text, files, pngs)

    def save(self, out: ReportOutput, ctx: RunContext) -> list[str]:
        for name, blob in out.plots.items():
            write_bytes(ctx.run_dir / name, blob)
        write_text(ctx.run_dir / REPORT_MD, out.text)
        write_map_stats(ctx.run_dir / MAP_STATS_JSON, out.map_stats, out.notes)
        return [MAP_STATS_JSON, REPORT_MD, *out.plots]

    def load(self, ctx: RunContext, files: list[str]) -> ReportOutput:
        stats, notes = read_map_stats(ctx.run_dir / MAP_STATS_JSON)
        written = [f for f in files if f.endswith(PNG)]
        return ReportOutput(stats, notes, written=written)
