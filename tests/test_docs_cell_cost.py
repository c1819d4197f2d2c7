"""The cost of a benchmark cell in the docs follows from the committed measurements (``benchmarks/out``)."""

from __future__ import annotations

import json
import re
from pathlib import Path

from committed_results import BENCHMARKS_OUT

ROOT = Path(__file__).resolve().parents[1]
SERIAL = ("world", "submaps", "posegraph", "report")


def _standard() -> dict:
    return json.loads((BENCHMARKS_OUT / "benchmark.json").read_text(encoding="utf-8"))["standard"]


def _worlds() -> dict[str, int]:
    """The standard suite's worlds per level, in its order."""
    from roman_sim.benchmark.suites import load_suite

    suite = load_suite("standard")
    return {lv: suite.worlds_needed(lv) for lv in suite.levels}


def _doc() -> str:
    return (ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8")


def test_the_cost_model_constants_follow_from_the_run() -> None:
    b = _standard()
    cells, k = b["cells"], b["constants"]
    assert set(cells) == set(b["stages_s"]) and len(cells) == sum(_worlds().values())
    for cid, c in cells.items():
        assert c["serial_s"] == round(sum(b["stages_s"][cid].get(s) or 0.0 for s in SERIAL), 2), cid
    serial = sum(c["serial_s"] for c in cells.values())
    align = sum(c["align_cpu_s"] for c in cells.values())
    km = sum(c["km"] for c in cells.values())
    assert k["s"] == round(serial / len(cells), 1)
    assert k["a"] == round(align / sum(c["pairs"] for c in cells.values()), 4)
    assert k["m"] == round((b["cpu_s"] - b["planning_cpu_s"] - serial - align) / km, 1)
    assert sum(b["level_cpu_s"].values()) + b["planning_cpu_s"] <= b["cpu_s"] + 60  # samples every 10 s, 2 cores
    text = " ".join(_doc().split())
    said = (
        f"s = {k['s']:g} s of serial stages per cell (mean wall time), alignment a = {k['a'] * 1000:.1f} CPU ms "
        f"per pair for the six methods together (their timed pairs), and mapping m = {k['m']:g} CPU s per km"
    )
    assert said in text


def test_cell_cost_table_follows_from_the_measurements() -> None:
    b = _standard()
    cells, k = b["cells"], b["constants"]

    def t(c: dict, n: int) -> float:
        return k["s"] + c["km"] * k["m"] / min(n, c["robots"]) + c["pairs"] * k["a"] / n

    table = _doc().split("<!-- cell-cost:begin -->")[1].split("<!-- cell-cost:end -->")[0]
    rows = table.strip().splitlines()[2:]
    assert [r.split("|")[1].strip() for r in rows] == list(_worlds())
    for row in rows:
        level, n, robots, km, pairs, *shown = [x.strip() for x in row.strip("|").split("|")]
        cs = [c for cid, c in cells.items() if cid.startswith(level + "-")]
        assert int(n) == len(cs) == _worlds()[level]
        assert {c["robots"] for c in cs} == {int(robots)}
        assert km == f"{sum(c['km'] for c in cs) / len(cs):.2f}" and int(pairs) == round(
            sum(c["pairs"] for c in cs) / len(cs)
        )
        means = [sum(t(c, nw) for c in cs) / len(cs) for nw in (2, 10, 100)]
        assert shown == [f"{b['level_cpu_s'][level] / len(cs):.0f}", *(f"{v:.0f}" for v in means)], level
    for nw in (2, 10, 100):
        total = b["planning_cpu_s"] / nw + sum(t(c, nw) for c in cells.values())
        assert b["model_min"][str(nw)] == round(total / 60, 1), nw
    m = re.search(
        r"\| `standard` \| (\d+) \| (\d+\.\d\d) \| (\d+\.\d) k \| (\d+) s \(measured\) \| (\d+\.\d) min "
        r"measured \(load ([\d.]+)-([\d.]+)\) \| about ([\d.]+) / ([\d.]+) min \|",
        _doc(),
    )
    assert m, "docs/benchmark.md no longer states the standard suite's cost"
    assert int(m[1]) == len(cells) and m[2] == f"{sum(c['km'] for c in cells.values()):.2f}"
    assert m[3] == f"{sum(c['pairs'] for c in cells.values()) / 1000:.1f}" and int(m[4]) == b["cpu_s"]
    assert float(m[5]) == b["wall_min"] and [float(m[6]), float(m[7])] == b["load"]
    assert [float(m[8]), float(m[9])] == [b["model_min"]["10"], b["model_min"]["100"]]


def test_the_cost_of_an_extra_world_is_the_table_s() -> None:
    b = _standard()
    rows = {
        r.split("|")[1].strip(): [x.strip() for x in r.strip("|").split("|")]
        for r in _doc().split("<!-- cell-cost:begin -->")[1].split("<!-- cell-cost:end -->")[0].strip().splitlines()[2:]
    }
    low, medium = rows["low"], rows["medium"]
    said = (
        f"An extra world adds one such cell: about {low[5]} CPU s at low ambiguity and {medium[5]} at medium, "
        f"{low[6]} s and {medium[6]} s of wall time on 2 cores by the model."
    )
    assert said in " ".join(_doc().split())
    assert int(low[5]) == round(b["level_cpu_s"]["low"] / _worlds()["low"]) and int(medium[5]) == round(
        b["level_cpu_s"]["medium"] / _worlds()["medium"]
    )
