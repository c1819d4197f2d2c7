"""The cost and transfer of ``roman-sim tune`` the docs state follow from ``benchmarks/out/tune.json``."""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_tune_figures_in_the_docs():
    d = json.loads((ROOT / "benchmarks" / "out" / "tune.json").read_text(encoding="utf-8"))
    text = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    assert d["suite"] == "quick" and d["method"] == "roman" and d["workers"] == 2
    assert not any(d["maps_reused"].values()) and len(d["worlds"]) == 3  # every world mapped fresh
    lb, la = d["load_before"], d["load_after"]
    assert (
        f"{d['wall_s']:.0f} s of wall time on a 2-core machine shared with other jobs (load average "
        f"{min(lb):.1f}-{max(lb):.0f} before, {min(la):.1f}-{max(la):.1f} after)" in text
    )
    rec, h, c = d["recommended"], d["held_out"], d["check_on_unseen_worlds"]
    ((name, value),) = rec["values"].items()
    lo, hi = h["precision_worlds"]
    assert (
        f"Recommended: `{name}` {value:g}, threshold {rec['threshold']}, held-out precision {h['precision']:.2f} "
        f"({h['hits']} / {h['hits'] + h['false_positives']}) with a 95 % world interval [{lo:.2f}, {hi:.2f}], "
        f"recall {h['hits'] / h['n_relevant']:.2f} ({h['hits']} / {h['n_relevant']})" in text
    )
    assert (
        f"that setting reached precision {c['precision']:.2f} ({c['hits']} / {c['hits'] + c['false_positives']}): "
        "below the target and below the stated interval" in text
    )
    assert c["precision"] < 0.9 and c["precision"] < lo and d["within_stated_interval"] is False
