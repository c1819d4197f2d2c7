"""Every plot a run's report lists, and every benchmark figure, checked on its figure object.

The smoke run's report stage draws its figures again in this process with ``Figure.savefig``
watched, so each figure is checked as it is saved: a title, labelled axes (with units on
maps), a legend or colour bar, every title, label and legend inside the saved image, a
size a page can hold and no text below 6 points; maps are drawn to scale (equal aspect) and
the map view carries a scale bar. The benchmark figures are drawn from the committed
``standard`` leaderboard.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from committed_results import REFERENCE, STANDARD
from matplotlib.axes import Axes
from matplotlib.collections import Collection, PathCollection
from matplotlib.colors import to_rgba, to_rgba_array
from matplotlib.container import Container
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
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
    """The figures saved while it watches ``Figure.savefig``, each once with the area its PNG shows (the tight
    bounding box for ``bbox_inches="tight"``, else the figure), and the handles every legend made meanwhile was
    given (``legend_handles``)."""

    def __init__(self) -> None:
        self.figures: list[tuple[Figure, Bbox]] = []
        self.legends: list[tuple[Legend, list[Any]]] = []
        self.formats: dict[int, list[str]] = {}

    def watch(self, mp: pytest.MonkeyPatch) -> None:
        real, real_legend = Figure.savefig, Legend.__init__
        seen, legends, formats = self.figures, self.legends, self.formats

        def savefig(fig: Figure, fname: Any, *args: Any, **kwargs: Any) -> Any:
            out = real(fig, fname, *args, **kwargs)  # lays the figure out as saved
            fmt = kwargs.get("format") or Path(str(fname)).suffix[1:]
            formats.setdefault(id(fig), []).append(fmt)
            if fmt == "png":
                renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
                tight = kwargs.get("bbox_inches") == "tight"
                area = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans) if tight else fig.bbox
                seen.append((fig, area))
            return out

        def legend(leg: Legend, parent: Any, handles: Any, labels: Any, *args: Any, **kwargs: Any) -> None:
            legends.append((leg, list(handles)))
            real_legend(leg, parent, handles, labels, *args, **kwargs)

        mp.setattr(Figure, "savefig", savefig)
        mp.setattr(Legend, "__init__", legend)

    def one(self) -> tuple[Figure, Bbox]:
        """The one figure saved since the last call (saved as a PNG and then a PDF), laid out again as its PNG."""
        ((fig, area),) = self.figures
        self.figures.clear()
        assert self.formats.pop(id(fig)) == ["png", "pdf"], "a figure is saved as a PNG with its PDF copy"
        fig.canvas.draw()  # the PDF was drawn last, at 72 dpi: lay the texts out as the PNG shows them
        return fig, area

    def legend_handles(self, leg: Legend) -> list[Any]:
        """The handles ``leg`` was made with (the artists drawn, or proxies standing for them)."""
        return next(h for lg, h in self.legends if lg is leg)


def _finite(xy: Any) -> bool:
    a = np.asarray(xy, dtype=float).reshape(-1, 2)
    return bool(np.isfinite(a).all(axis=1).any())


def _has_data(a: Any) -> bool:
    """Whether an artist of the axes shows something: a finite point, a path with vertices, a patch, an image."""
    if isinstance(a, Container):
        return any(_has_data(c) for c in a.get_children())
    if isinstance(a, Line2D):
        return _finite(a.get_xydata())
    if isinstance(a, Collection):
        if len(a.get_offsets()) and not np.allclose(a.get_offsets(), 0):
            return _finite(a.get_offsets())
        return any(_finite(p.vertices) for p in a.get_paths() if len(p.vertices))
    return a.get_visible()


def _rgb(c: Any) -> tuple[float, ...]:
    return tuple(round(v, 3) for v in to_rgba(c)[:3])


def _colours(a: Any) -> set[tuple[float, ...]]:
    if isinstance(a, Container):
        return set().union(*(_colours(c) for c in a.get_children()))
    if isinstance(a, Line2D):
        cs = [a.get_color(), a.get_markerfacecolor(), a.get_markeredgecolor()]
    elif isinstance(a, Collection):
        cs = [*a.get_facecolor(), *a.get_edgecolor()]
    elif isinstance(a, Patch):
        cs = [a.get_facecolor(), a.get_edgecolor()]
    else:
        cs = []
    return {_rgb(c) for c in cs if not isinstance(c, str) or c not in ("none", "auto")}


def _filled(a: Any) -> bool:
    faces = a.get_facecolor() if isinstance(a, (Patch, Collection)) else []
    return bool(len(faces)) and bool(np.asarray(to_rgba_array(faces))[:, 3].max() > 0)


def _stands_for(proxy: Any, a: Any) -> bool:
    """Whether a proxy handle stands for drawn artist ``a``: a coloured proxy, any artist drawn in its colour; a
    grey one (a kind of mark in any colour), an artist of its kind (line style and marker; filled or hollow)."""
    colour = proxy.get_color() if isinstance(proxy, Line2D) else proxy.get_facecolor()
    if isinstance(proxy, Patch) and not _filled(proxy):
        colour = proxy.get_edgecolor()
    r, g, b = _rgb(colour)
    if not r == g == b:
        return (r, g, b) in _colours(a)
    if isinstance(proxy, Patch):
        return isinstance(a, (Patch, Collection)) and _filled(a) == _filled(proxy)
    marker, style = proxy.get_marker(), proxy.get_linestyle()
    if style in ("None", "none", "", " "):  # marks only: a point set
        return isinstance(a, PathCollection) or (isinstance(a, Line2D) and a.get_marker() == marker)
    return isinstance(a, Line2D) and a.get_linestyle() == style and (marker in ("None", "") or a.get_marker() == marker)


def legend_problems(fig: Figure, saved: Saved) -> list[str]:
    """``label: why`` for each legend entry of ``fig`` that lists nothing drawn: an artist without data, or a proxy
    no drawn artist with data corresponds to."""
    drawn = [
        a
        for ax in fig.axes
        for a in (*ax.lines, *ax.collections, *ax.patches, *ax.images, *ax.containers)
        if _has_data(a)
    ]
    ours = {id(a) for ax in fig.axes for a in (*ax.get_children(), *ax.containers)}
    out = []
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None:
            continue
        for h, t in zip(saved.legend_handles(leg), leg.get_texts()):
            if id(h) in ours:
                out += [] if _has_data(h) else [f"{t.get_text()}: its {type(h).__name__} has no data"]
            elif not any(_stands_for(h, a) for a in drawn):
                out.append(f"{t.get_text()}: a proxy {type(h).__name__} that nothing drawn looks like")
    return out


#: Points of clear space every text keeps from every other (two texts closer read as one: "1379/1724371/726").
TEXT_GAP_PT = 2.0


def text_overlaps(fig: Figure) -> list[tuple[str, str]]:
    """Pairs of texts of ``fig`` (cells, ticks, labels, titles, legends) closer than ``TEXT_GAP_PT`` on the drawn
    figure (``get_window_extent`` of each text, grown by half the gap on every side)."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    half = TEXT_GAP_PT / 2 * fig.dpi / 72
    texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text()]
    boxes = [(t.get_text(), t.get_window_extent(r).padded(half)) for t in texts]
    return [(a, b) for (a, ba), (b, bb) in itertools.combinations(boxes, 2) if ba.overlaps(bb)]


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


@pytest.fixture(scope="module")
def benchmark_figures(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, tuple[Figure, Bbox]], Saved]:
    """The benchmark's figures from the committed leaderboard (the per-level PR figure from the demo's metrics,
    which has no relevant pair below 60 deg), with the watcher that saw them drawn."""
    if not (STANDARD / "leaderboard.json").is_file() or not (DEMO / "metrics.json").is_file():
        pytest.skip("no committed standard benchmark or demo run")
    from roman_sim.benchmark import board_plots as bp
    from roman_sim.benchmark.board_records import read_leaderboard
    from roman_sim.evaluation.results import read_metrics_json

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
    return figures, saved


def test_every_benchmark_figure_is_checked(benchmark_figures) -> None:
    figures, _ = benchmark_figures
    assert sorted(figures) == ["heatmap.png", "pr_heading_low.png", "recall_heading.png", "runtime.png"]
    for name, (fig, area) in figures.items():
        check_figure(name, fig, area)


def test_every_benchmark_legend_lists_only_what_is_drawn(benchmark_figures) -> None:
    """The demo's 0-60 deg bin has no relevant pair: its panel, where no curve has a point, is not drawn (it
    used to be, empty, with a legend of five lines)."""
    figures, saved = benchmark_figures
    for name, (fig, _) in sorted(figures.items()):
        assert not legend_problems(fig, saved), (name, legend_problems(fig, saved))
    pr, _ = figures["pr_heading_low.png"]
    assert [ax.get_title() for ax in pr.axes] == ["60-120 deg (4 relevant)", "120-180 deg (40 relevant)"]
    assert all(ax.get_legend() is not None for ax in pr.axes)


def test_no_two_texts_of_the_standard_heatmap_overlap(benchmark_figures) -> None:
    """Cells held "1379/1724" at 8 points in 0.58 inches: neighbours ran into each other, a pixel apart (the
    committed heatmap.png still shows it). Every text of the drawn figure now keeps clear of every other."""
    fig, _ = benchmark_figures[0]["heatmap.png"]
    texts = [t for t in fig.findobj(Text) if t.get_text()]
    assert len(texts) > 6 * 9  # the cells of six methods, and ticks, labels and titles
    assert text_overlaps(fig) == []


def test_the_heatmap_cells_are_readable_and_have_a_colour_bar(benchmark_figures) -> None:
    from roman_sim.benchmark.board_records import read_leaderboard

    board = read_leaderboard(STANDARD / "leaderboard.json")
    fig, _ = benchmark_figures[0]["heatmap.png"]
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


def _crowded_board(n_bins: int, levels: int, methods: list[str], counts: tuple[int, int]) -> Any:
    """A leaderboard of ``methods`` with ``n_bins`` heading bins and ``levels`` levels, every cell's relevant pairs
    drawn from ``counts`` (low, high) with a fixed seed."""
    from roman_sim.benchmark.board_records import BoardCell, BoardLevel, Leaderboard
    from roman_sim.evaluation.operating_points import OperatingPoint

    rng = np.random.default_rng(3)
    edges = [180.0 * i / n_bins for i in range(n_bins + 1)]
    out = []
    for li in range(levels):
        bins = []
        for lo, hi in zip(edges[:-1], edges[1:]):
            points = {}
            for m in methods:
                n = int(rng.integers(*counts))
                h = int(rng.integers(0, n + 1))
                points[m] = {"max_recall": OperatingPoint(3, True, h, n, 0, h / n, (0.0, 1.0), 1.0, (0.0, 1.0))}
            bins.append(BoardCell(f"{lo:g}-{hi:g}", 1, 1, points, {}, None))
        out.append(BoardLevel(f"level{li}", float(li), [], 3, ambiguity_index=li / levels, overall=bins[0], bins=bins))
    return Leaderboard("crowded", "", methods, [], edges, 0.1, {}, out)


@pytest.mark.parametrize(
    ("n_bins", "levels", "methods", "counts"),
    [
        (
            12,
            5,
            ["roman", "clipper", "clipper_prune", "ransac100k", "ransac1m", "visual", "pkg.mod:MyAligner"],
            (50_000, 1_000_000),
        ),
        (6, 3, ["roman", "a_rather_long_method_name"], (1000, 9999)),
        (4, 2, ["roman"], (10_000, 99_999)),
    ],
    ids=["12-bins-7-methods-6-digits", "6-bins-4-digits", "one-method-5-digits"],
)
def test_a_crowded_heatmap_keeps_its_texts_apart(
    n_bins: int, levels: int, methods: list[str], counts: tuple[int, int], tmp_path: Path
) -> None:
    from roman_sim.benchmark import board_plots as bp

    board = _crowded_board(n_bins, levels, methods, counts)
    saved, mp = Saved(), pytest.MonkeyPatch()
    saved.watch(mp)
    try:
        assert bp.plot_heatmap(board, tmp_path / "heatmap.png") is not None
        fig, _ = saved.one()
    finally:
        mp.undo()
    cells = [t for ax in fig.axes for t in ax.texts]
    assert len(cells) == n_bins * levels * len(methods)
    assert min(t.get_fontsize() for t in cells) >= 6
    assert text_overlaps(fig) == []
    p = board.levels[0].bins[0].point(methods[0], "max_recall")
    assert cells[0].get_text() == f"{p.recall:.2f}\n{bp.short_count(p.hits)}/{bp.short_count(p.n_relevant)}"
    assert (tmp_path / "heatmap.pdf").read_bytes().startswith(b"%PDF")


def test_counts_are_abbreviated_from_five_digits() -> None:
    from roman_sim.benchmark.board_plots import short_count

    cases = {0: "0", 9999: "9999", 10_000: "10k", 12_345: "12.3k", 123_456: "123k", 999_499: "999k"}
    cases |= {999_500: "1M", 1_234_567: "1.23M", 2_500_000_000: "2.5G"}
    assert {n: short_count(n) for n in cases} == cases
