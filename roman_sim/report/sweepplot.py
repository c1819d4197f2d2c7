"""The sweep's figure: mean max recall against the swept values, per method, one panel per bin."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from roman_sim.core.figures import drawn_legend, save_figure
from roman_sim.evaluation.sweepstats import OVERALL, SweepCell, param_values
from roman_sim.evaluation.types import PAIR_SET_LABELS
from roman_sim.report.plots import figure


def _x_values(rows: list[SweepCell], param_keys: list[str]) -> tuple[list[tuple[object, ...]], list[str]]:
    """Distinct parameter combinations in order, and their tick labels."""
    combos = list(dict.fromkeys(param_values(r.params, param_keys) for r in rows))
    labels = [
        ", ".join(f"{p.rsplit('.', 1)[-1]}={v}" for p, v in zip(param_keys, c)) if param_keys else "base"
        for c in combos
    ]
    return combos, labels


def plot_sweep(rows: list[SweepCell], param_keys: list[str], path: str | Path, kind: str) -> Path | None:
    """Mean max recall against the swept values per method, one panel per bin; None with one value."""
    mine = [r for r in rows if r.kind == kind and r.mean_recall is not None]
    combos, labels = _x_values(mine, param_keys)
    bins = list(dict.fromkeys(r.bin for r in mine))
    if len(combos) < 2 or not bins:
        return None
    methods = list(dict.fromkeys(r.method for r in mine))
    fig = figure(4.0 * len(bins), 4.2, ncols=len(bins))
    for ax, b in zip(fig.axes, bins):
        for i, m in enumerate(methods):
            pts = []
            for x, c in enumerate(combos):
                r = next(
                    (r for r in mine if r.method == m and r.bin == b and param_values(r.params, param_keys) == c),
                    None,
                )
                if r is not None:
                    t_ci = r.ci_low is not None
                    lo, hi = (r.ci_low, r.ci_high) if t_ci else (r.wilson_low, r.wilson_high)
                    pts.append((x + 0.06 * (i - len(methods) / 2), r.mean_recall, lo, hi))
            if pts:
                px, py, plo, phi = (np.array(v, dtype=float) for v in zip(*pts))
                ax.errorbar(px, py, yerr=[py - plo, phi - py], marker="o", capsize=3, label=m, color=f"C{i}")
        ax.set_xticks(range(len(combos)), labels, rotation=30, fontsize=7)
        ax.set(ylim=(0, 1.05), ylabel="max recall", title=f"{'overall' if b == OVERALL else b + ' deg'}")
        ax.grid(alpha=0.3)
        drawn_legend(ax, fontsize=7)
    n_seeds = max(r.n_seeds for r in mine)
    bars = "95 % t interval over seeds" if n_seeds >= 2 else "95 % Wilson interval (one seed)"
    fig.suptitle(
        f"Max recall over the sweep, {PAIR_SET_LABELS[kind]} pairs: mean of up to {n_seeds} seeds, {bars}", fontsize=9
    )
    return save_figure(fig, path)
