"""The README's cost of the image front end follows from the committed benchmark figures."""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_readme_pixels_cost_matches_the_benchmark():
    bench = json.loads((ROOT / "benchmarks" / "out" / "pixels.json").read_text(encoding="utf-8"))
    text = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    m = re.search(
        r"`demo_pixels` takes (\d+\.\d\d)x the CPU time of the demo .*? the (\d+) alternating pairs "
        r"of runs give (\d+\.\d\d)x to (\d+\.\d\d)x; .*? the target is (\d+(?:\.\d+)?)x",
        text,
    )
    assert m, "the README no longer states the image front end's cost"
    per_pair = bench["ratio_cpu_per_repeat"]
    assert float(m.group(1)) == round(bench["ratio_cpu"], 2)
    assert int(m.group(2)) == bench["repeats"] == len(per_pair)
    assert (float(m.group(3)), float(m.group(4))) == (round(min(per_pair), 2), round(max(per_pair), 2))
    assert float(m.group(5)) == bench["target_ratio"]
    # the fastest demo_pixels run against the fastest demo run, both recorded per pair
    runs = bench["runs"]
    assert bench["ratio_cpu"] == runs["demo_pixels"]["cpu_seconds"] / runs["demo"]["cpu_seconds"]
    assert runs["demo"]["cpu_seconds"] == min(r["cpu_seconds"] for r in runs["demo"]["repeats"])
    assert runs["demo_pixels"]["cpu_seconds"] == min(r["cpu_seconds"] for r in runs["demo_pixels"]["repeats"])
    assert per_pair == [
        p["cpu_seconds"] / d["cpu_seconds"] for d, p in zip(runs["demo"]["repeats"], runs["demo_pixels"]["repeats"])
    ]
