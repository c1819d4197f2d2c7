"""Sweep aggregation over seeds, by hand: mean, t interval, pooled hits with Wilson, the plot."""

from __future__ import annotations

import pytest

from roman_sim.evaluation.intervals import wilson
from roman_sim.evaluation.sweepstats import AGGREGATE_FIELDS, SeedRow, aggregate, cell
from roman_sim.report.sweepplot import plot_sweep


def _rows() -> list[SeedRow]:
    out = []
    for knob, per_seed in ((0.0, [(6, 10), (8, 10), (7, 10)]), (1.0, [(2, 10), (0, 0), (4, 10)])):
        for seed, (h, n) in enumerate(per_seed):
            out.append(SeedRow({"knob": knob}, seed, "roman", "inter", "all", h, n))
    return out


def test_mean_interval_and_pooled_counts_by_hand():
    rows = {r.params["knob"]: r for r in aggregate(_rows(), ["knob"])}
    a, b = rows[0.0], rows[1.0]
    # recalls 0.6, 0.8, 0.7: mean 0.7, sd 0.1, t(0.975, 2) = 4.302653 -> half-width 0.248414
    assert a.n_seeds == 3 and a.mean_recall == pytest.approx(0.7)
    assert (a.ci_low, a.ci_high) == pytest.approx((0.7 - 0.248414, 0.7 + 0.248414), abs=1e-6)
    assert (a.hits, a.relevant, a.pooled_recall) == (21, 30, pytest.approx(0.7))
    assert (a.wilson_low, a.wilson_high) == pytest.approx(wilson(21, 30))
    # a seed without relevant pairs is left out, not counted as recall 0
    assert b.n_seeds == 2 and b.mean_recall == pytest.approx(0.3) and b.relevant == 20
    assert cell(a).startswith("0.70 [0.45, 0.95] (3 seeds)")
    assert list(a.csv_row()) == ["knob", *AGGREGATE_FIELDS]  # the columns of sweep_summary.csv


def test_sweep_plot_needs_two_swept_values(tmp_path):
    rows = aggregate(_rows(), ["knob"])
    path = plot_sweep(rows, ["knob"], tmp_path / "s.png", "inter")
    assert path is not None and path.read_bytes().startswith(b"\x89PNG")
    assert plot_sweep([r for r in rows if r.params["knob"] == 0.0], ["knob"], tmp_path / "t.png", "inter") is None
