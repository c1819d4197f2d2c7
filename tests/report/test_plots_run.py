"""Every plot a run's report lists (drawn by ``roman_sim.report``), checked on its figure object.

The smoke run's report stage draws its figures again in this process with ``Figure.savefig``
watched, so each figure is checked as it is saved (``figure_checks``): a title, labelled axes
(with units on maps), a legend or colour bar, every title, label and legend inside the saved
image, a size a page can hold and no text below 6 points; maps are drawn to scale (equal
aspect) and the map view carries a scale bar. The benchmark's figures are checked the same
way in ``tests/benchmark/test_board_plots.py``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from figure_checks import Saved, check_figure, legend_problems
from matplotlib.figure import Figure
from matplotlib.transforms import Bbox

from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.manifest import read_manifest
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.stages import STAGES


@pytest.fixture(scope="module")
def run_figures(
    smoke_run: RunResult,
) -> tuple[dict[str, tuple[Figure, Bbox]], dict[str, dict[str, bytes]], list[str], Saved]:
    """The smoke run's report figures drawn again here, job by job: (figures by file name, the files the stage
    keeps by PNG path, suffix -> bytes, its notes on plots not drawn, the watcher with the legends made)."""
    from roman_sim.pipeline.stages.report import plot_jobs

    d = smoke_run.run_dir
    ctx = RunContext(smoke_run.scenario, d)
    man = read_manifest(d)
    outputs = {s.name: s.load(ctx, man.stages[s.name].files) for s in STAGES if s.name in man.stages}
    stage = next(s for s in STAGES if s.name == "report")
    saved = Saved()
    figures: dict[str, tuple[Figure, Bbox]] = {}
    files: dict[str, dict[str, bytes]] = {}
    notes: list[str] = []
    mp = pytest.MonkeyPatch()
    saved.watch(mp)
    try:
        for job in plot_jobs(ctx, stage.build_inputs(outputs)):
            drawn, more = job.fn(*job.args)
            notes += more
            if drawn is not None:
                files[job.name] = drawn
                figures[Path(job.name).name] = saved.one()
            assert not saved.figures, job.name
    finally:
        mp.undo()
    return figures, files, notes, saved


def test_every_plot_of_the_report_is_checked(run_figures) -> None:
    figures, files, notes, _ = run_figures
    names = {Path(p).name for p in files}
    assert {"map_view.png", "trajectories.png", "precision_recall.png"} <= names
    assert any(n.startswith("alignment_") for n in names)
    assert names <= set(figures), sorted(names - set(figures))
    for name in sorted(names):
        fig, area = figures[name]
        check_figure(name, fig, area)
    for n in notes:  # a plot not drawn says which and why
        if " not drawn" in n:
            assert re.match(r"^plot [\w.-]+\.png not drawn: \S", n), n


def test_the_report_lists_each_plot_or_why_it_is_missing(run_figures, smoke_run: RunResult) -> None:
    _, files, notes, _ = run_figures
    text = (smoke_run.run_dir / "report.md").read_text(encoding="utf-8")
    for p, drawn in files.items():
        assert f"]({p})" in text, p
        assert (smoke_run.run_dir / p).read_bytes() == drawn[".png"], p  # the stage wrote the figure drawn here
    for n in notes:
        if " not drawn" in n:
            assert f"- {n}" in text, n


def test_every_plot_has_its_vector_copy_with_the_same_bytes_in_every_process(run_figures, smoke_run: RunResult) -> None:
    """The stage drew the figures in its own run (a pool's workers or the main process), this test again here:
    each PDF is beside its PNG in the run folder with the very bytes drawn here (no date, no random id)."""
    _, files, _, _ = run_figures
    d = smoke_run.run_dir
    assert sorted(p.relative_to(d).as_posix() for p in (d / "plots").glob("*.pdf")) == sorted(
        str(Path(p).with_suffix(".pdf")) for p in files
    )
    for p, drawn in files.items():
        pdf = (d / p).with_suffix(".pdf").read_bytes()
        assert pdf.startswith(b"%PDF") and pdf == drawn[".pdf"], p
        assert b"/CreationDate" not in pdf and b"/Producer" not in pdf, p
    assert b"/Subtype /Image" in (d / "plots" / "segments_on_image.pdf").read_bytes()  # the camera image


def test_every_legend_of_the_report_lists_only_what_is_drawn(run_figures) -> None:
    figures, _, _, saved = run_figures
    with_legend = [n for n, (fig, _) in figures.items() if any(ax.get_legend() for ax in fig.axes)]
    assert {"map_view.png", "trajectories.png", "precision_recall.png"} <= set(with_legend)
    for name, (fig, _) in sorted(figures.items()):
        assert not legend_problems(fig, saved), (name, legend_problems(fig, saved))


def test_the_map_view_has_a_scale_a_legend_and_every_robot(run_figures, smoke_run: RunResult) -> None:
    fig, _ = run_figures[0]["map_view.png"]
    (ax,) = fig.axes
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
    assert ax.get_title().startswith(f"{smoke_run.scenario.name}: segment maps from above (true submap poses)")
    scale = [t.get_text() for t in ax.texts if re.fullmatch(r"\d+(\.\d+)? m", t.get_text())]
    assert len(scale) == 1
    length = float(scale[0][:-2])
    x0, x1 = ax.get_xlim()
    assert 0.1 <= length / (x1 - x0) <= 0.25  # a round length near a fifth of the width
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    robots = sorted(p.stem for p in (smoke_run.run_dir / "submaps").glob("*.npz"))
    assert len(robots) >= 2
    assert [f"robot {r}" for r in robots] == [lab for lab in labels if lab.startswith("robot ")]
    assert "submap centres, in order" in labels


def test_the_example_figures_say_how_their_false_positive_was_chosen(run_figures, smoke_run: RunResult) -> None:
    figures, _, _, _ = run_figures
    k = smoke_run.metrics.acceptance_k or 1
    for name, (fig, _) in figures.items():
        if name.startswith("alignment_"):
            title = fig._suptitle.get_text()  # noqa: SLF001
            assert title.startswith(f"{name[len('alignment_') : -4]}: a correct alignment and the worst false positive")
            assert f">= {k} associations" in title, title
