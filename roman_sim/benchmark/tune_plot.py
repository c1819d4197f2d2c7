"""The front of a tune (``roman-sim tune``): held-out recall against false loop closures per km.

One point per config (aligner and gating setting, each at thresholds chosen on other worlds)
with its world-bootstrap recall interval, coloured by time per pair; the Pareto front (recall,
false closures per km, time) joined and ringed; the recommended config starred. The plotted
data is stored in the PNG (``roman_sim.core.figures.read_png_data``); a PDF copy is written beside it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from roman_sim.core.figures import save_figure
from roman_sim.report.plots import figure

if TYPE_CHECKING:
    from roman_sim.benchmark.tune_result import TuneResult


def front_data(result: TuneResult) -> dict[str, Any]:
    """What ``plot_front`` draws, from a tune's result."""
    rec = result.recommended
    return {
        "configs": [
            {
                "id": c.id,
                "recall": c.recall,
                "recall_worlds": c.recall_worlds,
                "false_per_km": c.false_per_km,
                "time_per_pair_s": c.time_per_pair_s,
                "on_front": c.on_front,
            }
            for c in result.configs
        ],
        "recommended": None if rec is None else rec.config,
    }


def plot_front(result: TuneResult, path: str | Path) -> Path:
    """Draw the front of a tune's ``result`` to ``path``."""
    data = front_data(result)
    fig = figure(6.5, 4.5)
    ax = fig.axes[0]
    pts = [c for c in data["configs"] if c["recall"] is not None]
    times = [c["time_per_pair_s"] for c in pts if c["time_per_pair_s"] is not None]
    lo, hi = (min(times), max(times)) if times else (0.0, 1.0)
    for c in pts:
        x, y = c["false_per_km"], c["recall"]
        ci = c["recall_worlds"]
        t = c["time_per_pair_s"]
        shade = 0.5 if t is None or hi <= lo else 0.15 + 0.7 * (t - lo) / (hi - lo)
        colour = (shade, 0.3, 1.0 - shade)
        if ci is not None:
            ax.errorbar([x], [y], yerr=[[y - ci[0]], [ci[1] - y]], fmt="none", ecolor=colour, alpha=0.5)
        ax.plot([x], [y], "o", color=colour, ms=5)
        if c["on_front"]:
            ax.plot([x], [y], "o", mfc="none", mec="k", ms=9)
        if c["id"] == data["recommended"]:
            ax.plot([x], [y], "*", color="gold", mec="k", ms=14, label="recommended")
    front = sorted((c["false_per_km"], c["recall"]) for c in pts if c["on_front"])
    if len(front) > 1:
        ax.plot([p[0] for p in front], [p[1] for p in front], "k--", lw=0.8, label="Pareto front")
    ax.set_xlabel("false loop closures per km (held-out)")
    ax.set_ylabel("recall (held-out, 95 % world bootstrap)")
    ax.set_title(f"tune {result.method}: thresholds for precision {result.target_precision} chosen on other worlds")
    ax.set_ylim(-0.02, 1.02)
    ax.text(
        0.99,
        0.98,
        "colour: time per pair, blue fast to red slow",
        transform=ax.transAxes,
        ha="right",
        va="top",
        fontsize=7,
    )
    if data["recommended"] is not None or len(front) > 1:
        ax.legend(loc="lower right", fontsize=8)
    return save_figure(fig, path, data)
