"""Every plot a run's report lists, and every benchmark figure, checked on its figure object.

The smoke run's report stage draws its figures again in this process with ``Figure.savefig``
watched, so each figure is checked as it is saved: a title, labelled axes (with units on
maps), a legend or colour bar, every title, label and legend inside the saved image, a
size a page can hold and no text below 6 points; maps are drawn to scale (equal aspect) and
the map view carries a scale bar. The benchmark figures are drawn from the committed
``standard`` leaderboard.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
from committed_results import REFERENCE, STANDARD
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.manifest import read_manifest
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.stages import STAGES

DEMO = REFERENCE / "demo"

#: Largest figure (inches): two columns of a page at most.
MAX_W, MAX_H = 12.0, 14.0
#: Maps: figures whose axes show metres in x and y.
MAPS = ("map_view.png", "trajectories.png", "alignment_")


class Saved:
    """The figures saved while it watches ``Figure.savefig``, each with the area saved (the tight bounding
    box for ``bbox_inches="tight"``, else the figure)."""

    def __init__(self) -> None:
        self.figures: list[tuple[Figure, Bbox]] = []

    def watch(self, mp: pytest.MonkeyPatch) -> None:
        real = Figure.savefig
        seen = self.figures

        def savefig(fig: Figure, fname: Any, *args: Any, **kwargs: Any) -> Any:
            out = real(fig, fname, *args, **kwargs)  # lays the figure out as saved
            renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
            tight = kwargs.get("bbox_inches") == "tight"
            seen.append((fig, fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans) if tight else fig.bbox))
            return out

        mp.setattr(Figure, "savefig", savefig)

    def one(self) -> tuple[Figure, Bbox]:
        """The one figure saved since the last call."""
        (fig,) = self.figures
        self.figures.clear()
        return fig


def _texts(fig: Figure) -> list[Text]:
    out = [t for t in (fig._suptitle,) if t is not None and t.get_text()]  # noqa: SLF001
    for ax in fig.axes:
        out += [t for t in (ax.title, ax.xaxis.label, ax.yaxis.label) if t.get_text()]
        leg = ax.get_legend()
        if leg is not None:
            out += [t for t in leg.get_texts() if t.get_text()]
    return out


def _data_axes(fig: Figure) -> list[Axes]:
    """Axes that show data on scales (not colour bars, not pictures drawn without axes)."""
    return [ax for ax in fig.axes if ax.axison and ax.get_label() != "<colorbar>"]


def check_figure(name: str, fig: Figure, area: Bbox) -> None:
    """The checks every figure passes (see the module docstring); assertion messages name the figure."""
    w, h = fig.get_size_inches()
    assert w <= MAX_W and h <= MAX_H, (name, w, h)
    assert area.width <= MAX_W * fig.dpi + 1 and area.height <= MAX_H * fig.dpi + 1, (name, area)
    titles = [fig._suptitle] + [ax.title for ax in fig.axes]  # noqa: SLF001
    assert any(t is not None and t.get_text() for t in titles), f"{name}: no title"
    data = _data_axes(fig)
    for ax in data:
        assert ax.get_xlabel() and ax.get_ylabel(), f"{name}: an axes without labels ({ax.get_title()!r})"
    has_key = any(ax.get_legend() is not None for ax in fig.axes) or any(
        ax.get_label() == "<colorbar>" for ax in fig.axes
    )
    assert has_key or not data, f"{name}: neither a legend nor a colour bar"
    r = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    for t in _texts(fig):
        ext = t.get_window_extent(r)
        inside = area.x0 - 1 <= ext.x0 and ext.x1 <= area.x1 + 1 and area.y0 - 1 <= ext.y0 and ext.y1 <= area.y1 + 1
        assert inside, (name, t.get_text(), ext, area)
        assert t.get_fontsize() >= 6, (name, t.get_text(), t.get_fontsize())
    if name.startswith(MAPS):
        for ax in data:
            assert ax.get_aspect() == 1.0, (name, "not to scale")
            assert "(m)" in ax.get_xlabel() and "(m)" in ax.get_ylabel(), (name, ax.get_xlabel(), ax.get_ylabel())


@pytest.fixture(scope="module")
def run_figures(smoke_run: RunResult) -> tuple[dict[str, tuple[Figure, Bbox]], dict[str, bytes], list[str]]:
    """The smoke run's report figures drawn again here, job by job: (figures by file name, the PNGs
    the stage keeps, its notes on plots not drawn)."""
    from roman_sim.pipeline.stages.report import plot_jobs

    d = smoke_run.run_dir
    ctx = RunContext(smoke_run.scenario, d)
    man = read_manifest(d)
    outputs = {s.name: s.load(ctx, man.stages[s.name].files) for s in STAGES if s.name in man.stages}
    stage = next(s for s in STAGES if s.name == "report")
    saved = Saved()
    figures: dict[str, tuple[Figure, Bbox]] = {}
    pngs: dict[str, bytes] = {}
    notes: list[str] = []
    mp = pytest.MonkeyPatch()
    saved.watch(mp)
    try:
        for job in plot_jobs(ctx, stage.build_inputs(outputs)):
            png, more = job.fn(*job.args)
            notes += more
            if png is not None:
                pngs[job.name] = png
                figures[Path(job.name).name] = saved.one()
            assert not saved.figures, job.name
    finally:
        mp.undo()
    return figures, pngs, notes


def test_every_plot_of_the_report_is_checked(run_figures) -> None:
    figures, pngs, notes = run_figures
    names = {Path(p).name for p in pngs}
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
    _, pngs, notes = run_figures
    text = (smoke_run.run_dir / "report.md").read_text(encoding="utf-8")
    for p, png in pngs.items():
        assert f"]({p})" in text, p
        assert (smoke_run.run_dir / p).read_bytes() == png, p  # the stage wrote the figure drawn here
    for n in notes:
        if " not drawn" in n:
            assert f"- {n}" in text, n


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
    figures, _, _ = run_figures
    k = smoke_run.metrics.acceptance_k or 1
    for name, (fig, _) in figures.items():
        if name.startswith("alignment_"):
            title = fig._suptitle.get_text()  # noqa: SLF001
            assert title.startswith(f"{name[len('alignment_') : -4]}: a correct alignment and the worst false positive")
            assert f">= {k} associations" in title, title


@pytest.fixture(scope="module")
def benchmark_figures(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Figure, Bbox]]:
    """The benchmark's figures from the committed leaderboard (the per-level PR figure from the demo's metrics)."""
    if not (STANDARD / "leaderboard.json").is_file() or not (DEMO / "metrics.json").is_file():
        pytest.skip("no committed standard benchmark or demo run")
    from roman_sim.evaluation.leaderboard import read_leaderboard
    from roman_sim.evaluation.results import read_metrics_json
    from roman_sim.report import benchmark_plots as bp

    board = read_leaderboard(STANDARD / "leaderboard.json")
    out = tmp_path_factory.mktemp("bench")
    saved = Saved()
    figures: dict[str, tuple[Figure, Bbox]] = {}
    mp = pytest.MonkeyPatch()
    saved.watch(mp)
    try:
        for name, draw in (
            ("heatmap.png", bp.plot_heatmap),
            ("recall_heading.png", bp.plot_recall_heading),
            ("runtime.png", bp.plot_runtime),
        ):
            assert draw(board, out / name) is not None
            figures[name] = saved.one()
        assert bp.plot_pr_level(board, read_metrics_json(DEMO / "metrics.json"), "low", out / "pr.png") is not None
        figures["pr_heading_low.png"] = saved.one()
    finally:
        mp.undo()
    return figures


def test_every_benchmark_figure_is_checked(benchmark_figures) -> None:
    assert sorted(benchmark_figures) == ["heatmap.png", "pr_heading_low.png", "recall_heading.png", "runtime.png"]
    for name, (fig, area) in benchmark_figures.items():
        check_figure(name, fig, area)


def test_the_heatmap_cells_are_readable_and_have_a_colour_bar(benchmark_figures) -> None:
    from roman_sim.evaluation.leaderboard import read_leaderboard

    board = read_leaderboard(STANDARD / "leaderboard.json")
    fig, _ = benchmark_figures["heatmap.png"]
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    (bar,) = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert bar.get_ylabel() == "max recall over k"
    assert [ax.get_title() for ax in panels] == list(board.methods)
    levels = board.finished_levels()
    for ax, m in zip(panels, board.methods):
        assert ax.get_xlabel() == "heading difference (deg)" and ax.get_ylabel() == "ambiguity level (index)"
        cells = [t for t in ax.texts]
        assert all(t.get_fontsize() >= 8 for t in cells)
        want = []
        for e in levels:
            for b in e.bins:
                p = b.point(m, "max_recall")
                assert p is not None and p.recall is not None
                want.append(f"{p.recall:.2f}\n{p.hits}/{p.n_relevant}")
        assert [t.get_text() for t in cells] == want
        # cells about as wide as tall on the page, not strips
        bbox = ax.get_window_extent()
        cw, ch = bbox.width / len(levels[0].bins), bbox.height / len(levels)
        assert 0.6 <= cw / ch <= 2.0, (m, cw, ch)
