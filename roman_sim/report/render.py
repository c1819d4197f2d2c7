"""A run's plots rendered to bytes in memory, so that the stage that computes them writes nothing to the run folder.

Every figure is a PNG with a vector PDF beside it (``roman_sim.core.figures``). The metric
plots (``plots.write_metric_plots``), the example alignments (``examples.draw_examples``)
and the mask overlay (``maskview.plot_masks``) are drawing functions that write their files
themselves. ``drawn_files`` runs such a function on a temporary folder and keeps the bytes
of the files it wrote; the report stage's ``save`` then writes those bytes into the run
folder. The bytes are the ones the function would have written in place (same data, same
bytes), and the temporary folder is removed at once.

``metric_plot_png``, ``method_examples_png``, ``map_view_job``, ``trajectory_plot_png`` and
``frontend_grades_png`` (and ``snapshot.snapshot_job``) draw one figure each and return
``Drawn`` (its files, or the note saying why it was not drawn), so that the report stage
can hand them to worker processes as independent tasks (``draw_job``).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import AlignResult
from roman_sim.core.errors import EvaluationError
from roman_sim.core.figures import PNG, FigureFiles, figure_files, read_figure_files
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.types import EvaluationMetrics
from roman_sim.mapping.types import Submap

if TYPE_CHECKING:
    from roman_sim.evaluation.grades import FrontEndGrades
    from roman_sim.report.examples import Example, ExampleRule
    from roman_sim.report.trajplot import ClosureLine, TrajectoryLike

#: What drawing one figure gives: its files (PNG and PDF bytes; None when not drawn) and the notes on why not.
Drawn = tuple[FigureFiles | None, list[str]]


def drawn_files(draw: Callable[[Path], Iterable[Path]]) -> dict[str, FigureFiles]:
    """PNG name -> the files (PNG and its vector copy) of every figure ``draw(folder)`` wrote and returned, in
    its order."""
    with tempfile.TemporaryDirectory(prefix="roman_sim_plots_") as tmp:
        return {p.name: read_figure_files(p) for p in draw(Path(tmp))}


def drawn_pngs(draw: Callable[[Path], Iterable[Path]]) -> dict[str, bytes]:
    """PNG name -> PNG bytes of every figure ``draw(folder)`` wrote and returned, in its order."""
    return {name: files[PNG] for name, files in drawn_files(draw).items()}


def _one(draw: Callable[[Path], Iterable[Path]]) -> FigureFiles | None:
    """The files of the one figure ``draw(folder)`` wrote (None when it wrote none)."""
    return next(iter(drawn_files(draw).values()), None)


def metric_plot_pngs(metrics: EvaluationMetrics) -> tuple[dict[str, bytes], list[str]]:
    """The metric plots (file name -> PNG) and a note per plot not drawn."""
    from roman_sim.report.plots import write_metric_plots

    notes: list[str] = []

    def draw(folder: Path) -> list[Path]:
        written, skipped = write_metric_plots(metrics, folder)
        notes.extend(skipped)
        return written

    return drawn_pngs(draw), notes


def example_pngs(
    scores: list[PairScore],
    submaps: dict[str, Submap],
    results: dict[tuple[str, str, str], AlignResult],
    rule: ExampleRule | None = None,
) -> dict[str, bytes]:
    """``alignment_<method>.png`` per method (``examples.draw_examples``), file name -> PNG."""
    from roman_sim.report.examples import draw_examples

    return drawn_pngs(lambda folder: draw_examples(scores, submaps, results, folder, rule))


def draw_job(fn: Callable[..., Drawn], *args: object) -> Drawn:
    """``fn(*args)``: one figure drawn as a worker's task (``fn`` is one of this module's drawing functions)."""
    return fn(*args)


def metric_plot_png(metrics: EvaluationMetrics, name: str) -> Drawn:
    """The metric plot ``name`` (a key of ``plots.METRIC_PLOTS``), or the note on why it is not drawn."""
    from roman_sim.report.plots import write_metric_plot

    notes: list[str] = []

    def draw(folder: Path) -> list[Path]:
        path, note = write_metric_plot(metrics, name, folder)
        notes.extend([note] if note is not None else [])
        return [] if path is None else [path]

    return _one(draw), notes


def method_examples_png(method: str, rows: list[Example], title: str = "") -> Drawn:
    """``alignment_<method>.png`` from the method's example rows and title (``examples.example_rows``)."""
    from roman_sim.report.examples import plot_method_examples

    return _one(lambda folder: [plot_method_examples(method, rows, folder, title)]), []


def map_view_job(submaps: list[Submap], title: str = "") -> Drawn:
    """The map view (``mapview.map_view_png``; ``title``: the scenario), or the note on why it is not drawn."""
    from roman_sim.report.mapview import map_view_files

    try:
        return map_view_files(submaps, title=title), []
    except EvaluationError as err:
        return None, [f"plot map_view.png not drawn: {err}"]


def trajectory_plot_png(
    truth: Mapping[str, TrajectoryLike],
    est: Mapping[str, TrajectoryLike] | None,
    odom: Mapping[str, TrajectoryLike] | None,
    closures: Sequence[ClosureLine],
    title: str,
) -> Drawn:
    """The trajectory plot (``trajplot.trajectory_figure``), or the note on why it is not drawn."""
    from roman_sim.report.trajplot import trajectory_figure

    try:
        return figure_files(trajectory_figure(truth, est=est, odom=odom, closures=closures, title=title)), []
    except EvaluationError as err:
        return None, [f"plot trajectories.png not drawn: {err}"]


def masks_files(
    rgb: NDArray[np.uint8], masks: Sequence[NDArray[np.bool_]], title: str, labels: Sequence[str | None]
) -> FigureFiles:
    """The image with the masks over it (``maskview.plot_masks``): its PNG and PDF bytes."""
    from roman_sim.report.maskview import plot_masks

    files = _one(lambda folder: [plot_masks(rgb, masks, folder / "masks.png", title, labels)])
    assert files is not None  # plot_masks always writes its figure
    return files


def frontend_grades_png(grades: FrontEndGrades) -> Drawn:
    """The front end's grades (``grades.plot_frontend_grades``)."""
    from roman_sim.report.grades import plot_frontend_grades

    return _one(lambda folder: [plot_frontend_grades(grades, folder / "frontend.png")]), []
