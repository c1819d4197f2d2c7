"""Figures of a benchmark leaderboard (matplotlib, Agg canvas; same data, same bytes).

- ``recall_heading.png``: recall against heading difference per method with its 95 % band,
  one column per ambiguity level, at max recall (top) and at precision >= 0.9 (bottom);
- ``pr_heading_<level>.png``: precision-recall over k per heading bin, one panel per bin,
  operating points marked (triangle: precision >= 0.9, square: acceptance threshold);
- ``heatmap.png``: heading x ambiguity, one panel per method (two per row when they fit), max
  recall in colour (one labelled colour bar) with recall and hits / relevant written in each
  cell; cells and fonts are sized to their text, so no two numbers overlap;
- ``runtime.png``: runtime per pair per method (mean over every pair; the cells' medians
  and 90th percentiles as points), log scale;
- ``score_pr.png``: per level (one panel each) every method's precision-recall curve on the
  board's score over all headings (``BoardLevel.curves``), the 95 % world interval of the
  precision as a band, the area under the curve in the legend.

The drawing functions take the ``Leaderboard`` (and, for the PR curves, each level's
``EvaluationMetrics``). Each figure is written with a vector PDF beside its PNG
(``roman_sim.core.figures.save_figure``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from roman_sim.benchmark.board_records import Leaderboard
from roman_sim.core.figures import drawn_legend, remove_figure, save_figure
from roman_sim.evaluation.operating_points import POINT_LABELS
from roman_sim.evaluation.types import EvaluationMetrics
from roman_sim.report.plots import figure, heading_pr_panels


def benchmark_figures(board: Leaderboard) -> dict[str, str]:
    """Figure file -> caption, for the levels that have results."""
    levels = [e.name for e in board.finished_levels()]
    out = {"recall_heading.png": "Recall against heading difference (95 % bands): max recall and at precision >= 0.9"}
    for n in levels:
        out[f"pr_heading_{n}.png"] = f"Precision-recall per heading bin, ambiguity level {n}"
    out["heatmap.png"] = "Heading x ambiguity: max recall per method, hits / relevant in each cell"
    out["runtime.png"] = "Runtime per pair"
    if any(e.curves is not None for e in board.levels):
        out["score_pr.png"] = f"Precision-recall on `{board.score}` per level, 95 % world bands, area under the curve"
    return out


def _centres(board: Leaderboard) -> np.ndarray:
    e = np.asarray(board.heading_edges_deg, dtype=float)
    return (e[:-1] + e[1:]) / 2


def recall_heading_data(board: Leaderboard) -> dict[str, Any]:
    """What ``recall_heading.png`` shows: per level, point and method, each bin's
    ``[hits, relevant, recall, interval low, interval high]`` (None where the method has no point)."""
    levels = board.finished_levels()
    out: dict[str, Any] = {"bins": [b.heading for b in levels[0].bins] if levels else []}
    for e in levels:
        out[e.name] = {
            point: {
                m: [
                    None
                    if (p := b.point(m, point)) is None
                    else [p.hits, p.n_relevant, p.recall, *(p.recall_ci or [None, None])]
                    for b in e.bins
                ]
                for m in board.methods
            }
            for point in ("max_recall", "precision_90")
        }
    return out


def plot_recall_heading(board: Leaderboard, path: Path) -> Path | None:
    """Recall per heading bin with bands, per method; rows: levels; columns: max recall, precision >= 0.9.

    The curves are drawn from ``recall_heading_data(board)``, which the PNG carries
    (``read_png_data``)."""
    levels = [(e.name, e) for e in board.finished_levels()]
    if not levels:
        return None
    data = recall_heading_data(board)
    x = _centres(board)
    fig = figure(8.0, min(14.0, 2.7 * len(levels) + 0.4), ncols=2, nrows=len(levels))
    for row, (name, e) in enumerate(levels):
        for col, point in enumerate(("max_recall", "precision_90")):
            ax = fig.axes[row * 2 + col]
            for i, m in enumerate(board.methods):
                rows = data[name][point][m]  # per bin: [hits, relevant, recall, low, high] or None
                y, lo, hi = (
                    np.array([np.nan if r is None or r[j] is None else r[j] for r in rows], dtype=float)
                    for j in (2, 3, 4)
                )
                ax.plot(x, y, marker="o", color=f"C{i}", label=m)
                ax.fill_between(x, lo, hi, color=f"C{i}", alpha=0.15, linewidth=0)
            ax.set(xlim=(0, 180), ylim=(0, 1.02), xticks=board.heading_edges_deg)
            ax.set_title(f"{name} (index {_fmt(e.ambiguity_index)}): {POINT_LABELS[point]}", fontsize=8)
            ax.set_xlabel("heading difference (deg)", fontsize=8)
            ax.set_ylabel("recall", fontsize=8)
            ax.grid(alpha=0.3)
    drawn_legend(fig.axes[0], fig.axes, fontsize=7, loc="lower left")  # every method drawn in any panel
    return save_figure(fig, path, data)


def _fmt(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.2f}"


def plot_pr_level(board: Leaderboard, metrics: EvaluationMetrics, level: str, path: Path) -> Path | None:
    """Precision-recall over k per heading bin of one level (one panel per bin with relevant pairs; None when no
    bin has one), operating points marked."""
    sets = {m: metrics.method(m).set("inter") for m in board.methods if m in metrics.methods}
    if not sets:
        return None
    first = next(iter(sets.values()))
    bins = [i for i, b in enumerate(first.heading_bins) if b.stats.n_relevant]
    if not bins:
        return None
    fig = figure(max(3.4 * len(bins), 5.0), 3.8, ncols=len(bins))
    heading_pr_panels(fig.axes, sets, bins)
    fig.suptitle(
        f"Precision-recall over k per heading bin, level {level}\n(triangle: P >= 0.9, square: acceptance)", fontsize=10
    )
    return save_figure(fig, path)


#: Font sizes tried for the heatmap's cells and ticks, largest first, until the figure is at most
#: ``HEATMAP_MAX_W`` inches wide (two columns of a page); a board too large even then gets a wider figure.
CELL_FONTS = (8.0, 7.0, 6.0)
HEATMAP_MAX_W = 12.0
#: Inches: the room around a cell's text, the smallest cell, and a panel's margins beside it (tick labels,
#: axis label) and below and above it (ticks, axis label, title).
CELL_PAD, CELL_MIN_W, CELL_MIN_H, PANEL_W, PANEL_H = 0.16, 0.58, 0.5, 1.1, 1.2


def short_count(n: int) -> str:
    """A count in at most five characters: as it is below 10 000, else 12.3k, 123k, 1.23M, ..."""
    if n < 10_000:
        return str(n)
    for unit, div in (("k", 1e3), ("M", 1e6)):
        if n / div < 999.5:
            return f"{n / div:.3g}{unit}"
    return f"{n / 1e9:.3g}G"


def heatmap_cells(board: Leaderboard) -> dict[str, list[list[tuple[float | None, str]]]]:
    """Per method, per finished level (rows) and heading bin (columns): (max recall or None, the cell's text)."""
    out: dict[str, list[list[tuple[float | None, str]]]] = {}
    for m in board.methods:
        out[m] = []
        for e in board.finished_levels():
            row: list[tuple[float | None, str]] = []
            for b in e.bins:
                p = b.point(m, "max_recall")
                if p is not None and p.recall is not None and p.n_relevant:
                    row.append((p.recall, f"{p.recall:.2f}\n{short_count(p.hits)}/{short_count(p.n_relevant)}"))
                else:
                    row.append((None, "n/a"))
            out[m].append(row)
    return out


def _text_size(texts: list[str], size: float, dpi: float) -> tuple[float, float]:
    """Width and height (inches) of the widest and the tallest of ``texts`` (lines stacked) at ``size`` points."""
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.font_manager import FontProperties

    r, prop = RendererAgg(1, 1, dpi), FontProperties(size=size)
    lines = [line for t in texts for line in t.split("\n")]
    w = max(r.get_text_width_height_descent(line, prop, ismath=False)[0] for line in lines) / dpi
    return w, max(t.count("\n") + 1 for t in texts) * 1.2 * size / 72


def heatmap_layout(
    texts: list[str], ticks: list[str], n_bins: int, n_levels: int, n_methods: int, dpi: float = 90
) -> tuple[int, float, float, float]:
    """(panels per row, font size, cell width, cell height in inches) of a heatmap whose cells hold ``texts`` and
    whose bins are ticked ``ticks``: every text fits its cell with room to spare, at the largest size of
    ``CELL_FONTS`` and the most panels per row (two at most) that keep the figure within ``HEATMAP_MAX_W``."""
    for size in CELL_FONTS:
        w, h = _text_size([*texts, *ticks], size, dpi)
        cell_w, cell_h = max(CELL_MIN_W, w + CELL_PAD), max(CELL_MIN_H, h + CELL_PAD)
        for ncols in range(min(2, n_methods), 0, -1):
            if ncols * (cell_w * n_bins + PANEL_W) + 0.7 <= HEATMAP_MAX_W:
                return ncols, size, cell_w, cell_h
    return 1, size, cell_w, cell_h


def plot_heatmap(board: Leaderboard, path: Path) -> Path | None:
    """Max recall per (level, heading bin), one panel per method (two per row when they fit), recall and hits /
    relevant in each cell (counts from 10 000 abbreviated: 12.3k), and one colour bar for all panels.

    Cells, fonts and the figure are sized to the text (``heatmap_layout``), so no two texts overlap."""
    levels = [(e.name, e) for e in board.finished_levels()]
    if not levels:
        return None
    methods = list(board.methods)
    labels = [b.heading for b in levels[0][1].bins]
    cells = heatmap_cells(board)
    texts = [t for rows in cells.values() for row in rows for _, t in row]
    ncols, size, cell_w, cell_h = heatmap_layout(texts, labels, len(labels), len(levels), len(methods))
    nrows = int(np.ceil(len(methods) / ncols))
    height = nrows * (cell_h * len(levels) + PANEL_H) + 0.6
    fig = Figure(figsize=(ncols * (cell_w * len(labels) + PANEL_W) + 0.7, height), dpi=90)
    FigureCanvasAgg(fig)
    gs = fig.add_gridspec(nrows, ncols + 1, width_ratios=[1.0] * ncols + [0.04])
    cmap = colormaps["viridis"].with_extremes(bad="0.85")
    image = None
    for i, m in enumerate(methods):
        ax = fig.add_subplot(gs[i // ncols, i % ncols])
        grid = np.full((len(levels), len(labels)), np.nan)
        for r, row in enumerate(cells[m]):
            for c, (recall, text) in enumerate(row):
                colour = "black" if recall is None or recall >= 0.5 else "white"
                grid[r, c] = np.nan if recall is None else recall
                ax.text(c, r, text, ha="center", va="center", fontsize=size, color=colour)
        image = ax.imshow(grid, vmin=0.0, vmax=1.0, cmap=cmap, aspect="auto")
        ax.set_xticks(range(len(labels)), labels, fontsize=size)
        ax.set_yticks(range(len(levels)), [f"{n}\n({_fmt(e.ambiguity_index)})" for n, e in levels], fontsize=size)
        ax.set_xlabel("heading difference (deg)", fontsize=8)
        ax.set_ylabel("ambiguity level (index)", fontsize=8)
        ax.set_title(m, fontsize=10)
    assert image is not None  # board.methods is never empty when a level finished
    bar = fig.colorbar(image, cax=fig.add_subplot(gs[:, ncols], label="<colorbar>"))
    bar.set_label("max recall over k")
    fig.suptitle(  # 0.1 inch from the top however tall the figure (tight_layout keeps the room below it)
        "Max recall per ambiguity level and heading difference\n(each cell: recall, hits / relevant)",
        fontsize=10,
        y=1 - 0.1 / height,
    )
    return save_figure(fig, path)


def plot_runtime(board: Leaderboard, path: Path) -> Path | None:
    """Runtime per pair per method: the mean (bar), the cells' medians (dots) and 90th percentiles (crosses)."""
    rt = board.runtime
    if not rt:
        return None
    names = list(rt)
    fig = figure(max(5.0, 0.9 * len(names) + 2.0), 3.6)
    ax = fig.axes[0]
    x = np.arange(len(names))
    ax.bar(x, [1000 * rt[m].mean_s for m in names], color=[f"C{i}" for i in range(len(names))], alpha=0.6)
    for i, m in enumerate(names):
        med = [1000 * v for v in rt[m].cell_medians_s]
        p90 = [1000 * v for v in rt[m].cell_p90_s]
        ax.scatter(np.full(len(med), i - 0.1), med, color="black", s=10, label="cell median")
        ax.scatter(np.full(len(p90), i + 0.1), p90, color="black", marker="x", s=12, label="cell p90")
    ax.set_xticks(x, names, fontsize=8)
    ax.set_yscale("log")
    ax.set(xlabel="method", ylabel="ms per pair (log scale)")
    ax.set_title("Runtime per pair (bar: mean)\nwall clock on the machine that ran it", fontsize=9)
    ax.grid(axis="y", alpha=0.3)
    drawn_legend(ax, fontsize=7)
    return save_figure(fig, path)


def score_pr_data(board: Leaderboard) -> dict[str, Any]:
    """What ``score_pr.png`` shows: per level with curves, per method ``auc`` and its curve's points
    ``[threshold, recall, precision, precision low, precision high]``."""
    return {
        e.name: {
            m: {
                "auc": c.auc,
                "points": [[p.threshold, p.recall, p.precision, *_pair(p.precision_worlds)] for p in c.points],
            }
            for m, c in e.curves.methods.items()
        }
        for e in board.levels
        if e.curves is not None
    }


def _pair(ci: list[float] | None) -> list[float | None]:
    return [None, None] if ci is None else [ci[0], ci[1]]


def plot_score_pr(board: Leaderboard, path: Path) -> Path | None:
    """Per level a panel: each method's precision over recall on the board's score, the precision's world band.

    Drawn from ``score_pr_data(board)``, which the PNG carries (``read_png_data``)."""
    data = score_pr_data(board)
    if not data:
        return None
    fig = figure(3.8 * len(data), 3.8, ncols=len(data))
    for ax, (level, methods) in zip(fig.axes, data.items(), strict=True):
        for i, m in enumerate(board.methods):
            if m not in methods:
                continue
            pts = np.array([[np.nan if v is None else v for v in r[1:]] for r in methods[m]["points"]], dtype=float)
            ok = ~np.isnan(pts[:, 0]) & ~np.isnan(pts[:, 1])
            r, prec, lo, hi = (pts[ok, j] for j in range(4))
            ax.plot(r, prec, marker=".", color=f"C{i}", label=f"{m} (AUC {_fmt(methods[m]['auc'])})")
            ax.fill_between(r, lo, hi, color=f"C{i}", alpha=0.15, linewidth=0)
        ax.set(xlim=(0, 1), ylim=(0, 1.02), xlabel="recall", ylabel="precision")
        ax.set_title(f"{level}: precision-recall on {board.score}", fontsize=8)
        ax.grid(alpha=0.3)
        drawn_legend(ax, fontsize=6, loc="upper right")
    return save_figure(fig, path, data)


def write_benchmark_plots(board: Leaderboard, metrics: dict[str, EvaluationMetrics], plots_dir: Path) -> list[Path]:
    """Every figure of ``benchmark_figures`` that has data, into ``plots_dir``; the paths written."""
    out = []
    for name in benchmark_figures(board):
        path = plots_dir / name
        if name == "recall_heading.png":
            got = plot_recall_heading(board, path)
        elif name == "heatmap.png":
            got = plot_heatmap(board, path)
        elif name == "runtime.png":
            got = plot_runtime(board, path)
        elif name == "score_pr.png":
            got = plot_score_pr(board, path)
        else:
            level = name[len("pr_heading_") : -len(".png")]
            got = plot_pr_level(board, metrics[level], level, path)
        if got is None:
            remove_figure(path)
        else:
            out.append(got)
    return out
