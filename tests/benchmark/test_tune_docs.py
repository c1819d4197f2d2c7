"""The cost and transfer of ``roman-sim tune`` the docs state follow from ``benchmarks/out/tune.json``."""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _ci(v: list[float]) -> str:
    return f"[{v[0]:.2f}, {v[1]:.2f}]"


def test_tune_figures_in_the_docs():
    d = json.loads((ROOT / "benchmarks" / "out" / "tune.json").read_text(encoding="utf-8"))
    text = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    assert d["suite"] == "quick" and d["method"] == "roman" and d["workers"] == 1  # one process: all CPU counted
    assert not any(d["maps_reused"].values()) and len(d["worlds"]) == 3  # every world mapped fresh
    lb, la = d["load_before"], d["load_after"]
    assert (
        f"in one process: {d['cpu_s']:.0f} s of CPU time, so about {d['cpu_s'] / 2:.0f} s on 2 free cores if both "
        f"were kept busy ({d['cpu_s']:.0f} s on one). The wall time, {d['wall_s']:.0f} s, was taken on a 2-core "
        f"machine shared with other jobs (load average {min(lb):.1f}-{max(lb):.1f} before, "
        f"{min(la):.1f}-{max(la):.1f} after)" in text
    )
    assert d["cpu_over_2_cores_s"] == round(d["cpu_s"] / 2, 1)
    rec, h, c = d["recommended"], d["held_out"], d["check_on_unseen_worlds"]
    ((name, value),) = rec["values"].items()
    cal_hits = round(rec["calibration_recall"] * h["n_relevant"])
    assert abs(cal_hits / h["n_relevant"] - rec["calibration_recall"]) < 1e-9
    assert (
        f"Recommended: `{name}` {value:g}, threshold {rec['threshold']}, at a calibration recall of "
        f"{rec['calibration_recall']:.2f} ({cal_hits} / {h['n_relevant']})" in text
    )
    assert (
        f"{h['hits']} hits and {h['false_positives']} false positive, precision {h['precision']:.2f} with a 95 % "
        f"world interval {_ci(h['precision_worlds'])} and, for one new world, {_ci(h['precision_new_world'])}" in text
    )
    assert h["hits"] + h["false_positives"] == 1  # "a statement about one accepted pair"
    accepted = [w for w, v in c["per_world"].items() if v["precision"] is not None]
    n = len(c["per_world"])
    assert c["seeds"] == [1, 2, 3] and n == 9
    assert (
        f"that setting reached precision {c['precision']:.2f} ({c['hits']} / {c['hits'] + c['false_positives']}, "
        f"Wilson {_ci(c['precision_wilson'])}) at recall {c['recall']:.2f} ({c['hits']} / {c['n_relevant']}); "
        f"{n - len(accepted)} of the 9 worlds accepted nothing, none of the {len(accepted)} that accepted a pair "
        "lies in the one-new-world interval, and no seed's precision pooled over the levels lies in the pooled "
        "interval" in text
    )
    assert c["worlds_inside_new_world_interval"] == [0, len(accepted)]
    assert c["seeds_inside_pooled_interval"][0] == 0
    assert d["reaches_target"] is True and d["within_stated_interval"] is False
    assert "The target is reached, but not within the stated interval" in text
