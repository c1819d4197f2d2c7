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
from typing import Any

from roman_sim.evaluation.intervals import mean_interval, wilson
from roman_sim.evaluation.run_summary import RecallSummary, RunSummary

#: The bin of a run's overall figure.
OVERALL = "all"
AGGREGATE_FIELDS = [
    "method",
    "kind",
    "bin",
    "n_seeds",
    "mean_recall",
    "ci_low",
    "ci_high",
    "hits",
    "relevant",
    "pooled_recall",
    "wilson_low",
    "wilson_high",
]


def seed_rows(params: dict[str, Any], seed: int, summary: RunSummary) -> list[dict[str, Any]]:
    """Rows of one run's summary (``run_summary.RunSummary``): per method, pair set and bin its max-recall counts."""
    out = []
    for method, m in summary.methods.items():
        for kind in ("inter", "intra"):
            k = m.set(kind)
            parts: list[tuple[str, RecallSummary]] = [(OVERALL, k), *k.bins.items()]
            out += [
                {
                    **params,
                    "seed": seed,
                    "method": method,
                    "kind": kind,
                    "bin": label,
                    "hits": s.max_hits,
                    "relevant": s.n_relevant,
                }
                for label, s in parts
            ]
    return out


def _key(row: dict[str, Any], param_keys: list[str]) -> tuple[object, ...]:
    return (*(_hashable(row[p]) for p in param_keys), row["method"], row["kind"], row["bin"])


def _hashable(v: object) -> object:
    return repr(v) if isinstance(v, (dict, list)) else v


def aggregate(rows: Iterable[dict[str, Any]], param_keys: list[str], level: float = 0.95) -> list[dict[str, Any]]:
    """Summary rows (parameters, then ``AGGREGATE_FIELDS``) in first-seen order."""
    groups: dict[tuple[object, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(_key(r, param_keys), []).append(r)
    out = []
    for members in groups.values():
        first = members[0]
        used = [r for r in members if r["relevant"] > 0]
        mean, ci = mean_interval([r["hits"] / r["relevant"] for r in used], level)
        hits, rel = sum(r["hits"] for r in used), sum(r["relevant"] for r in used)
        w = wilson(hits, rel, level)
        out.append(
            {
                **{p: first[p] for p in param_keys},
                "method": first["method"],
                "kind": first["kind"],
                "bin": first["bin"],
                "n_seeds": len(used),
                "mean_recall": mean,
                "ci_low": None if ci is None else ci[0],
                "ci_high": None if ci is None else ci[1],
                "hits": hits,
                "relevant": rel,
                "pooled_recall": hits / rel if rel else None,
                "wilson_low": None if w is None else w[0],
                "wilson_high": None if w is None else w[1],
            }
        )
    return out


def cell(r: dict[str, Any]) -> str:
    """``mean [lo, hi] (n seeds)`` or, with one seed, ``recall (h/n) [Wilson]``."""
    if r["mean_recall"] is None:
        return "n/a"
    if r["ci_low"] is not None and not math.isnan(r["ci_low"]):
        return f"{r['mean_recall']:.2f} [{r['ci_low']:.2f}, {r['ci_high']:.2f}] ({r['n_seeds']} seeds)"
    return f"{r['pooled_recall']:.2f} ({r['hits']}/{r['relevant']}) [{r['wilson_low']:.2f}, {r['wilson_high']:.2f}]"
