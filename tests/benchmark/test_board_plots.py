"""Every benchmark figure (``roman_sim.benchmark.board_plots``) checked on its figure object as it is saved.

The figures are drawn from the committed ``standard`` leaderboard (the per-level PR figure
from the demo's metrics) and from made-up crowded leaderboards, with the checks every report
figure passes (``figure_checks``).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from committed_results import REFERENCE, STANDARD
from figure_checks import Saved, check_figure, legend_problems, text_overlaps
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from roman_sim.benchmark.board_records import MethodRuntime

DEMO = REFERENCE / "demo"


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


def test_the_benchmark_runtime_title_fits_its_figure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Two methods made the one-line title wider than the figure, cut on both sides."""
    import roman_sim.benchmark.board_plots as bp

    kept: list[Figure] = []
    real = bp.save_figure

    def keep(fig: Figure, path: str | Path, data: object = None) -> Path:
        out = real(fig, path, data)
        fig.canvas.draw()
        kept.append(fig)
        return out

    monkeypatch.setattr(bp, "save_figure", keep)
    cell = MethodRuntime(
        n=4, mean_s=0.002, cell_medians_s=[0.001, 0.002], cell_p10_s=[None, None], cell_p90_s=[0.003, 0.004]
    )
    board = SimpleNamespace(runtime={"roman": cell, "clipper": cell})
    assert bp.plot_runtime(board, tmp_path / "runtime.png") is not None  # type: ignore[arg-type]
    (fig,) = kept
    ax = fig.axes[0]
    ext, box = ax.title.get_window_extent(), fig.bbox
    assert box.x0 <= ext.x0 and ext.x1 <= box.x1, (ext, box)
    assert ax.get_xlabel() == "method" and ax.get_ylabel() == "ms per pair (log scale)" and ax.get_legend()
