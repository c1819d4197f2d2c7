"""Sweep aggregation over seeds: mean recall and its interval per swept value, method, pair set and bin.

Input: one row per (run, method, pair set, bin) with the swept parameters, the seed and the
max-recall hits / relevant of that run (``seed_rows``). Output, per (parameters, method,
pair set, bin): the number of seeds with relevant pairs, the mean of their recalls with a
Student-t 95 % interval (seed-to-seed spread; none with one seed), and the pooled hits /
relevant over the seeds with a Wilson interval (``aggregate``). ``plot_sweep`` draws the
mean against the swept value with error bars (the t interval when there are two seeds or
more, else the Wilson interval of the one run).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from roman_sim.evaluation.intervals import mean_interval, wilson
from roman_sim.evaluation.plots import figure, save_png
from roman_sim.evaluation.types import PAIR_SET_LABELS

#: The bin of a run's overall figure.
OVERALL = "all"
SUMMARY_FIELDS = ["method", "kind", "bin", "n_seeds", "mean_recall", "ci_low", "ci_high", "hits", "relevant",
                  "pooled_recall", "wilson_low", "wilson_high"]


def seed_rows(params: dict[str, Any], seed: int, summary: dict[str, Any]) -> list[dict[str, Any]]:
    """Rows of one run's compact summary (``summaries.compact_summary``)."""
    out = []
    for method, m in summary["methods"].items():
        for kind in ("inter", "intra"):
            k = m[kind]
            for label, s in [(OVERALL, k)] + list(k["bins"].items()):
                out.append({**params, "seed": seed, "method": method, "kind": kind, "bin": label,
                            "hits": int(s["max_hits"]), "relevant": int(s["n_relevant"])})
    return out


def _key(row: dict[str, Any], param_keys: list[str]) -> tuple[Any, ...]:
    return (*(_hashable(row[p]) for p in param_keys), row["method"], row["kind"], row["bin"])


def _hashable(v: Any) -> Any:
    return repr(v) if isinstance(v, (dict, list)) else v


def aggregate(rows: Iterable[dict[str, Any]], param_keys: list[str], level: float = 0.95) -> list[dict[str, Any]]:
    """Summary rows (parameters, then ``SUMMARY_FIELDS``) in first-seen order."""
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(_key(r, param_keys), []).append(r)
    out = []
    for members in groups.values():
        first = members[0]
        used = [r for r in members if r["relevant"] > 0]
        mean, ci = mean_interval([r["hits"] / r["relevant"] for r in used], level)
        hits, rel = sum(r["hits"] for r in used), sum(r["relevant"] for r in used)
        w = wilson(hits, rel, level)
        out.append({**{p: first[p] for p in param_keys}, "method": first["method"], "kind": first["kind"],
                    "bin": first["bin"], "n_seeds": len(used), "mean_recall": mean,
                    "ci_low": None if ci is None else ci[0], "ci_high": None if ci is None else ci[1],
                    "hits": hits, "relevant": rel, "pooled_recall": hits / rel if rel else None,
                    "wilson_low": None if w is None else w[0], "wilson_high": None if w is None else w[1]})
    return out


def _x_values(rows: list[dict[str, Any]], param_keys: list[str]) -> tuple[list[Any], list[str]]:
    """Distinct parameter combinations in order, and their tick labels."""
    combos = list(dict.fromkeys(tuple(_hashable(r[p]) for p in param_keys) for r in rows))
    labels = [", ".join(f"{p.rsplit('.', 1)[-1]}={v}" for p, v in zip(param_keys, c)) if param_keys else "base"
              for c in combos]
    return combos, labels


def plot_sweep(rows: list[dict[str, Any]], param_keys: list[str], path: str | Path, kind: str) -> Path | None:
    """Mean max recall against the swept values per method, one panel per bin; None with one value."""
    mine = [r for r in rows if r["kind"] == kind and r["mean_recall"] is not None]
    combos, labels = _x_values(mine, param_keys)
    bins = list(dict.fromkeys(r["bin"] for r in mine))
    if len(combos) < 2 or not bins:
        return None
    methods = list(dict.fromkeys(r["method"] for r in mine))
    fig = figure(4.0 * len(bins), 4.2, ncols=len(bins))
    for ax, b in zip(fig.axes, bins):
        for i, m in enumerate(methods):
            pts = []
            for x, c in enumerate(combos):
                r = next((r for r in mine if r["method"] == m and r["bin"] == b
                          and tuple(_hashable(r[p]) for p in param_keys) == c), None)
                if r is not None:
                    t_ci = r["ci_low"] is not None
                    lo, hi = (r["ci_low"], r["ci_high"]) if t_ci else (r["wilson_low"], r["wilson_high"])
                    pts.append((x + 0.06 * (i - len(methods) / 2), r["mean_recall"], lo, hi))
            if pts:
                px, py, plo, phi = (np.array(v, dtype=float) for v in zip(*pts))
                ax.errorbar(px, py, yerr=[py - plo, phi - py], marker="o", capsize=3, label=m, color=f"C{i}")
        ax.set_xticks(range(len(combos)), labels, rotation=30, fontsize=7)
        ax.set(ylim=(0, 1.05), ylabel="max recall", title=f"{'overall' if b == OVERALL else b + ' deg'}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    n_seeds = max(r["n_seeds"] for r in mine)
    bars = "95 % t interval over seeds" if n_seeds >= 2 else "95 % Wilson interval (one seed)"
    fig.suptitle(f"Max recall over the sweep, {PAIR_SET_LABELS[kind]} pairs: mean of up to {n_seeds} seeds, {bars}",
                 fontsize=9)
    return save_png(fig, path)


def cell(r: dict[str, Any]) -> str:
    """``mean [lo, hi] (n seeds)`` or, with one seed, ``recall (h/n) [Wilson]``."""
    if r["mean_recall"] is None:
        return "n/a"
    if r["ci_low"] is not None and not math.isnan(r["ci_low"]):
        return f"{r['mean_recall']:.2f} [{r['ci_low']:.2f}, {r['ci_high']:.2f}] ({r['n_seeds']} seeds)"
    return f"{r['pooled_recall']:.2f} ({r['hits']}/{r['relevant']}) [{r['wilson_low']:.2f}, {r['wilson_high']:.2f}]"
