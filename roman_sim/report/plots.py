"""Metric plots of a run (matplotlib, Agg canvas only; no pyplot global state).

Drawn from ``EvaluationMetrics`` (what ``metrics.json`` holds), for the headline pair set
(cross-robot when the run has cross-robot pairs), with same-robot pairs in their own panel
where they have relevant pairs:

- ``precision_recall.png``: precision over recall as the association threshold k rises;
- ``precision_recall_heading.png``: the same per coarse heading bin, with each method's
  operating points marked (triangle: precision >= 0.9, square: the acceptance threshold);
- ``recall_operating_points.png``: per coarse heading bin, recall at max recall, at
  precision >= 0.9, at precision 1 and at the pose graph's acceptance threshold, with
  counts and intervals;
- ``recall_heading.png`` / ``recall_heading_fine.png``: max recall per heading bin with its
  hits / relevant count and 95 % Wilson interval; bins with fewer than ``min_relevant``
  relevant pairs are hatched and marked ``n<N`` instead of showing a rate;
- ``recall_ambiguity.png``: max recall against place ambiguity, with intervals;
- ``association_heading.png``: association precision and recall per heading bin.

A plot that would carry a single point (one bin with data, a one-point curve) is not drawn;
``write_metric_plots`` returns a note saying so. Each plot is written with a vector PDF beside
its PNG (``roman_sim.core.figures.save_figure``: atomically, without timestamps, so the same
data gives the same bytes). A legend lists only what its plot draws: a method without a
point in a panel is left out of that panel's legend.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from roman_sim.core.figures import drawn_legend, remove_figure, save_figure
from roman_sim.evaluation.operating_points import POINT_LABELS, POINT_NAMES
from roman_sim.evaluation.types import (
    PAIR_SET_LABELS,
    BinStats,
    CurveStats,
    EvaluationMetrics,
    PairSetMetrics,
    PRCurve,
)


def figure(w: float = 6.0, h: float = 4.0, ncols: int = 1, nrows: int = 1) -> Figure:
    """A figure with an Agg canvas and ``nrows x ncols`` axes (``fig.axes``)."""
    fig = Figure(figsize=(w, h), dpi=90)
    FigureCanvasAgg(fig)
    fig.subplots(nrows, ncols, squeeze=False)
    return fig


def _points(c: PRCurve) -> int:
    return int(np.sum(~(np.isnan(c.recall) | np.isnan(c.precision))))


#: Operating point -> marker drawn on precision-recall curves.
POINT_MARKERS = {"precision_90": "^", "acceptance": "s"}


def pr_axes(ax: Axes, curves: dict[str, PRCurve], title: str, stats: dict[str, CurveStats] | None = None) -> None:
    """Precision over recall, one line per method; with ``stats``, each method's operating points marked."""
    for i, (name, c) in enumerate(curves.items()):
        ax.plot(c.recall, c.precision, marker=".", label=name, color=f"C{i}")
        pts = (stats or {}).get(name)
        for point, marker in POINT_MARKERS.items():
            p = pts.operating_points.get(point) if pts is not None else None
            if p is not None and p.reached and p.recall is not None and p.precision is not None:
                ax.scatter([p.recall], [p.precision], marker=marker, s=40, color=f"C{i}", edgecolors="black", zorder=3)
    ax.set(xlabel="recall", ylabel="precision", xlim=(0, 1.02), ylim=(0, 1.05), title=title)
    ax.grid(alpha=0.3)
    drawn_legend(ax, loc="best", fontsize=7)


def plot_pr(metrics: EvaluationMetrics, path: str | Path) -> Path | None:
    """Precision over recall as k rises, one line per method (None when no curve has two points)."""
    kind = metrics.headline
    curves = {m: mm.set(kind).pr_curve for m, mm in metrics.methods.items()}
    if max((_points(c) for c in curves.values()), default=0) < 2:
        return None
    fig = figure()
    rel = metrics.pairs[kind].n_relevant
    pr_axes(fig.axes[0], curves, f"Precision-recall over k, {PAIR_SET_LABELS[kind]} ({rel} relevant pairs)")
    return save_figure(fig, path)


def heading_pr_panels(axes: list[Axes], sets: dict[str, PairSetMetrics], bins: list[int]) -> None:
    """One precision-recall panel (``pr_axes``) per heading bin index of ``bins``, on ``axes`` in order:
    every method of ``sets`` with its operating points, titled by the bin and its relevant pairs."""
    first = next(iter(sets.values()))
    for ax, i in zip(axes, bins):
        b = first.heading_bins[i]
        pr_axes(
            ax,
            {m: s.heading_pr[i] for m, s in sets.items()},
            f"{b.label} deg ({b.stats.n_relevant} relevant)",
            {m: s.heading_bins[i].stats for m, s in sets.items()},
        )


def plot_pr_heading(metrics: EvaluationMetrics, path: str | Path) -> Path | None:
    """Precision-recall per coarse heading bin (one panel per bin with relevant pairs; None if < 2)."""
    kind = metrics.headline
    sets = {m: mm.set(kind) for m, mm in metrics.methods.items()}
    first = next(iter(sets.values()), None)
    bins = [i for i, b in enumerate(first.heading_bins) if b.stats.n_relevant] if first else []
    if len(bins) < 2:
        return None
    fig = figure(4.2 * len(bins), 4.0, ncols=len(bins))
    heading_pr_panels(fig.axes, sets, bins)
    fig.suptitle(
        f"Precision-recall over k per heading bin, {PAIR_SET_LABELS[kind]} pairs "
        "(triangle: precision >= 0.9, square: acceptance threshold)",
        fontsize=10,
    )
    return save_figure(fig, path)


Getter = Callable[[CurveStats], tuple[float | None, int, int, tuple[float, float] | None]]


def _recall(s: CurveStats) -> tuple[float | None, int, int, tuple[float, float] | None]:
    return s.max_recall, s.max_hits, s.n_relevant, s.recall_ci


def _assoc_precision(s: CurveStats) -> tuple[float | None, int, int, tuple[float, float] | None]:
    return s.assoc_precision, s.assoc_correct, s.assoc_selected, s.assoc_precision_ci


def _assoc_recall(s: CurveStats) -> tuple[float | None, int, int, tuple[float, float] | None]:
    return s.assoc_recall, s.assoc_recovered, s.assoc_available, s.assoc_recall_ci


def _bars(ax: Axes, rows: dict[str, list[BinStats]], get: Getter, min_n: int, ylabel: str) -> None:
    """Grouped bars per bin and method: rate, Wilson interval, ``hits/n``; small bins hatched.

    A bin in which no method has a denominator is left out (an empty bin is not data).
    """
    names = list(rows)
    first = rows[names[0]] if names else []
    keep = [i for i in range(len(first)) if any(get(r[i].stats)[2] for r in rows.values())]
    labels = [first[i].label for i in keep]
    width = 0.8 / max(len(names), 1)
    x = np.arange(len(labels))
    drawn: list[int] = []  # the methods with a bar, the only ones the legend lists
    for i, name in enumerate(names):
        pos = x - 0.4 + width * (i + 0.5)
        colour = f"C{i}"
        for p, b in zip(pos, [rows[name][j] for j in keep]):
            v, k, n, ci = get(b.stats)
            if n == 0 or v is None:
                ax.text(p, 0.02, "none", ha="center", va="bottom", fontsize=6, rotation=90)
                continue
            small = n < min_n
            if i not in drawn:
                drawn.append(i)
            ax.bar(p, v, width, color=colour, alpha=0.35 if small else 1.0, hatch="//" if small else None)
            if ci is not None and not small:
                ax.errorbar(p, v, yerr=[[v - ci[0]], [ci[1] - v]], fmt="none", ecolor="black", capsize=2, lw=0.8)
            top = v if ci is None or small else ci[1]
            ax.text(
                p,
                top + 0.03,
                f"{k}/{n}" + (f" n<{min_n}" if small else ""),
                ha="center",
                va="bottom",
                fontsize=6,
                rotation=90,
            )
    ax.set_xticks(x, labels)
    ax.set_xlim(-0.5, len(labels) - 0.5)
    ax.set_ylim(0, 1.35)
    ax.set_yticks(np.linspace(0, 1, 6))
    ax.set_ylabel(ylabel)
    ax.grid(axis="y", alpha=0.3)
    if drawn:
        ax.legend(
            [Patch(color=f"C{i}") for i in drawn],
            [names[i] for i in drawn],
            fontsize=7,
            loc="upper left",
            ncols=min(len(drawn), 4),
        )


def point_getter(name: str) -> Getter:
    """Recall, hits, relevant and interval of operating point ``name`` (a point never reached: 0)."""

    def get(s: CurveStats) -> tuple[float | None, int, int, tuple[float, float] | None]:
        p = s.operating_points.get(name)
        if p is None:
            return None, 0, 0, None
        return p.recall, p.hits, p.n_relevant, p.recall_ci

    return get


def plot_operating_points(metrics: EvaluationMetrics, path: str | Path) -> Path | None:
    """Recall at each operating point per coarse heading bin (headline set); None if < 2 bins have data."""
    kind = metrics.headline
    rows = {m: mm.set(kind).heading_bins for m, mm in metrics.methods.items()}
    first = next(iter(rows.values()), [])
    names = [n for n in POINT_NAMES if first and any(b.stats.operating_points.get(n) for b in first)]
    if not names or _with_data(rows, point_getter(names[0])) < 2:
        return None
    min_n = metrics.config.min_relevant
    n_bins = _with_data(rows, point_getter(names[0]))
    fig = figure(max(6.0, 0.35 * n_bins * len(rows) + 2.0), 3.4 * len(names), nrows=len(names))
    for ax, name in zip(fig.axes, names):
        label = POINT_LABELS[name] + (f" (k={metrics.acceptance_k})" if name == "acceptance" else "")
        _bars(ax, rows, point_getter(name), min_n, "recall")
        ax.set(xlabel="heading difference (deg)", title=f"{PAIR_SET_LABELS[kind]} pairs: {label}, hits/relevant")
    fig.suptitle("Recall at each operating point per heading bin (95 % Wilson intervals)", fontsize=9)
    return save_figure(fig, path)


def _with_data(rows: dict[str, list[BinStats]], get: Getter) -> int:
    """Bins in which some method has a denominator."""
    first = next(iter(rows.values()), [])
    return sum(1 for i in range(len(first)) if any(get(r[i].stats)[2] for r in rows.values()))


def plot_heading_recall(metrics: EvaluationMetrics, path: str | Path, fine: bool = False) -> Path | None:
    """Max recall per heading bin with counts and intervals: one panel per pair set with relevant pairs."""
    table = "heading_bins_fine" if fine else "heading_bins"
    kinds = [k for k in ("inter", "intra") if metrics.pairs[k].n_relevant]
    per_kind = {k: {m: getattr(mm.set(k), table) for m, mm in metrics.methods.items()} for k in kinds}
    kinds = [k for k in kinds if _with_data(per_kind[k], _recall) >= 2]
    if not kinds:
        return None
    n_bins = max(_with_data(per_kind[k], _recall) for k in kinds)
    fig = figure(max(6.0, 0.35 * n_bins * len(metrics.methods) + 2.0), 3.8 * len(kinds), nrows=len(kinds))
    fig.suptitle(
        f"Max recall per heading bin (95 % Wilson intervals; hatched: fewer than "
        f"{metrics.config.min_relevant} relevant pairs)",
        fontsize=9,
    )
    for ax, k in zip(fig.axes, kinds):
        _bars(ax, per_kind[k], _recall, metrics.config.min_relevant, "max recall")
        ax.set(xlabel="heading difference (deg)", title=f"{PAIR_SET_LABELS[k]} pairs: max recall, hits/relevant")
    return save_figure(fig, path)


def plot_ambiguity_recall(metrics: EvaluationMetrics, path: str | Path) -> Path | None:
    """Max recall against place ambiguity (headline pair set) with intervals; None if < 2 bins have data."""
    kind = metrics.headline
    rows = {m: mm.set(kind).ambiguity_bins for m, mm in metrics.methods.items()}
    if _with_data(rows, _recall) < 2:
        return None
    fig = figure()
    ax = fig.axes[0]
    min_n = metrics.config.min_relevant
    for i, (name, bins) in enumerate(rows.items()):
        pts = [((b.lo + b.hi) / 2 + 0.008 * i, b.stats) for b in bins if b.stats.n_relevant]
        big = [(x, s) for x, s in pts if not s.few]
        if big:
            y = np.array([s.max_recall for _, s in big], dtype=float)
            err = np.array([[v - s.recall_ci[0], s.recall_ci[1] - v] for v, (_, s) in zip(y, big)]).T  # type: ignore[index]
            ax.errorbar([x for x, _ in big], y, yerr=err, marker="o", capsize=2, color=f"C{i}", label=name)
        small = [(x, s) for x, s in pts if s.few]
        ax.scatter(
            [x for x, _ in small],
            [float(s.max_recall or 0.0) for _, s in small],
            facecolors="none",
            edgecolors=f"C{i}",
            label=f"{name}, < {min_n} relevant" if small else None,
        )
    ax.set(
        xlabel="place ambiguity",
        ylabel="max recall",
        ylim=(0, 1.05),
        title=f"Recall against ambiguity, {PAIR_SET_LABELS[kind]} (95 % Wilson)",
    )
    ax.grid(alpha=0.3)
    drawn_legend(ax, fontsize=7)
    return save_figure(fig, path)


def plot_association(metrics: EvaluationMetrics, path: str | Path) -> Path | None:
    """Association precision and recall per coarse heading bin (headline pair set)."""
    kind = metrics.headline
    rows = {m: mm.set(kind).heading_bins for m, mm in metrics.methods.items()}
    if _with_data(rows, _assoc_recall) < 2:
        return None
    fig = figure(max(6.0, 0.35 * _with_data(rows, _assoc_recall) * len(rows) + 2.0), 7.6, nrows=2)
    for ax, get, what in (
        (fig.axes[0], _assoc_precision, "precision (correct/selected)"),
        (fig.axes[1], _assoc_recall, "recall (recovered/available)"),
    ):
        _bars(ax, rows, get, 1, f"association {what.split()[0]}")
        ax.set(xlabel="heading difference (deg)", title=f"{PAIR_SET_LABELS[kind]}: association {what}")
    return save_figure(fig, path)


#: Plot file -> (drawing function, what it would need).
METRIC_PLOTS: dict[str, tuple[Callable[[EvaluationMetrics, Path], Path | None], str]] = {
    "precision_recall.png": (plot_pr, "a precision-recall curve with two points"),
    "precision_recall_heading.png": (plot_pr_heading, "two heading bins with relevant pairs"),
    "recall_heading.png": (plot_heading_recall, "two heading bins with relevant pairs"),
    "recall_heading_fine.png": (
        lambda m, p: plot_heading_recall(m, p, fine=True),
        "two fine heading bins with relevant pairs",
    ),
    "recall_ambiguity.png": (plot_ambiguity_recall, "two ambiguity bins with relevant pairs"),
    "recall_operating_points.png": (plot_operating_points, "two heading bins with relevant pairs"),
    "association_heading.png": (plot_association, "two heading bins with true correspondences"),
}


def write_metric_plot(metrics: EvaluationMetrics, name: str, plots_dir: str | Path) -> tuple[Path | None, str | None]:
    """The metric plot ``name`` (a key of ``METRIC_PLOTS``) into ``plots_dir``: (path, None) or (None, the note
    on why it is not drawn)."""
    draw, needs = METRIC_PLOTS[name]
    path = Path(plots_dir) / name
    if draw(metrics, path) is None:
        remove_figure(path)
        return None, f"plot {name} not drawn: it needs {needs}{_bins_held(metrics, name)}"
    return path, None


#: Plot -> the bins (a ``PairSetMetrics`` attribute) whose relevant pairs it needs, and how a bin reads.
BINS_NEEDED = {
    "precision_recall_heading.png": ("heading_bins", "{} deg"),
    "recall_heading.png": ("heading_bins", "{} deg"),
    "recall_heading_fine.png": ("heading_bins_fine", "{} deg"),
    "recall_ambiguity.png": ("ambiguity_bins", "ambiguity {}"),
    "recall_operating_points.png": ("heading_bins", "{} deg"),
}


def _bins_held(metrics: EvaluationMetrics, name: str) -> str:
    """What the run has of the bins ``name`` needs, for its note: the one bin with relevant pairs, or none."""
    if name not in BINS_NEEDED or not metrics.methods:
        return ""
    attr, fmt = BINS_NEEDED[name]
    kind = metrics.headline
    bins: list[BinStats] = getattr(next(iter(metrics.methods.values())).set(kind), attr)
    held = [b for b in bins if b.stats.n_relevant]
    if not held:
        return f"; no bin has a relevant {PAIR_SET_LABELS[kind]} pair"
    if len(held) == 1:
        one = held[0]
        return f"; only {fmt.format(one.label)} has relevant {PAIR_SET_LABELS[kind]} pairs ({one.stats.n_relevant})"
    return ""


def write_metric_plots(metrics: EvaluationMetrics, plots_dir: str | Path) -> tuple[list[Path], list[str]]:
    """The metric plots into ``plots_dir``: (paths written, notes on plots not drawn)."""
    written, notes = [], []
    for name in METRIC_PLOTS:
        path, note = write_metric_plot(metrics, name, plots_dir)
        if path is not None:
            written.append(path)
        if note is not None:
            notes.append(note)
    return written, notes
