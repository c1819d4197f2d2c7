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
from dataclasses import dataclass, fields

from roman_sim.core.jsontypes import JSON
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


@dataclass(frozen=True)
class SeedRow:
    """One run's max-recall counts of one method, pair set and bin, with the run's swept values."""

    params: dict[str, JSON]
    seed: int
    method: str
    kind: str
    bin: str
    hits: int
    relevant: int

    def key(self, param_keys: list[str]) -> tuple[object, ...]:
        """The swept values of ``param_keys`` (hashable), then method, pair set and bin."""
        return (*param_values(self.params, param_keys), self.method, self.kind, self.bin)


@dataclass(frozen=True)
class SweepCell:
    """One swept setting, method, pair set and bin over the seeds: mean recall with its t interval
    (None with one seed) and pooled hits / relevant with a Wilson interval."""

    params: dict[str, JSON]
    method: str
    kind: str
    bin: str
    n_seeds: int
    mean_recall: float | None
    ci_low: float | None
    ci_high: float | None
    hits: int
    relevant: int
    pooled_recall: float | None
    wilson_low: float | None
    wilson_high: float | None

    def csv_row(self) -> dict[str, JSON]:
        """The swept values, then ``AGGREGATE_FIELDS`` (a row of ``sweep_summary.csv``)."""
        return {**self.params, **{f.name: getattr(self, f.name) for f in fields(self) if f.name != "params"}}


def param_values(params: dict[str, JSON], param_keys: list[str]) -> tuple[object, ...]:
    """The values of ``param_keys`` in ``params``, hashable (a list or mapping as its ``repr``)."""
    return tuple(_hashable(params[p]) for p in param_keys)


def seed_rows(params: dict[str, JSON], seed: int, summary: RunSummary) -> list[SeedRow]:
    """Rows of one run's summary (``run_summary.RunSummary``): per method, pair set and bin its max-recall counts."""
    out = []
    for method, m in summary.methods.items():
        for kind in ("inter", "intra"):
            k = m.set(kind)
            parts: list[tuple[str, RecallSummary]] = [(OVERALL, k), *k.bins.items()]
            out += [SeedRow(params, seed, method, kind, label, s.max_hits, s.n_relevant) for label, s in parts]
    return out


def _hashable(v: object) -> object:
    return repr(v) if isinstance(v, (dict, list)) else v


def aggregate(rows: Iterable[SeedRow], param_keys: list[str], level: float = 0.95) -> list[SweepCell]:
    """Summary rows (parameters, then ``AGGREGATE_FIELDS``) in first-seen order."""
    groups: dict[tuple[object, ...], list[SeedRow]] = {}
    for r in rows:
        groups.setdefault(r.key(param_keys), []).append(r)
    out = []
    for members in groups.values():
        first = members[0]
        used = [r for r in members if r.relevant > 0]
        mean, ci = mean_interval([r.hits / r.relevant for r in used], level)
        hits, rel = sum(r.hits for r in used), sum(r.relevant for r in used)
        w = wilson(hits, rel, level)
        out.append(
            SweepCell(
                params={p: first.params[p] for p in param_keys},
                method=first.method,
                kind=first.kind,
                bin=first.bin,
                n_seeds=len(used),
                mean_recall=mean,
                ci_low=None if ci is None else ci[0],
                ci_high=None if ci is None else ci[1],
                hits=hits,
                relevant=rel,
                pooled_recall=hits / rel if rel else None,
                wilson_low=None if w is None else w[0],
                wilson_high=None if w is None else w[1],
            )
        )
    return out


def cell(r: SweepCell) -> str:
    """``mean [lo, hi] (n seeds)`` or, with one seed, ``recall (h/n) [Wilson]``."""
    if r.mean_recall is None:
        return "n/a"
    if r.ci_low is not None and r.ci_high is not None and not math.isnan(r.ci_low):
        return f"{r.mean_recall:.2f} [{r.ci_low:.2f}, {r.ci_high:.2f}] ({r.n_seeds} seeds)"
    return f"{r.pooled_recall:.2f} ({r.hits}/{r.relevant}) [{r.wilson_low:.2f}, {r.wilson_high:.2f}]"
