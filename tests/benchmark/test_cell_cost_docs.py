"""The cost of a benchmark cell in the docs follows from the committed measurements (``benchmarks/out``)."""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_cell_cost_table_follows_from_the_measurements():
    data = json.loads((ROOT / "benchmarks" / "out" / "benchmark.json").read_text(encoding="utf-8"))
    m, a = data["standard_part"]["m_cpu_s_per_km"], data["standard_part"]["a_cpu_s_per_pair"]
    text = (ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8")
    assert f"mapping m = {m:g} CPU s\nper km, alignment a = {a * 1000:.1f} CPU ms per pair" in text
    table = text.split("<!-- cell-cost:begin -->")[1].split("<!-- cell-cost:end -->")[0]
    rows = [r for r in table.strip().splitlines()[2:]]
    cells = data["standard_plan"]["cells"]
    assert len(rows) == len(cells)
    cpu = []
    for row in rows:
        name, robots, km, pairs, *shown = [x.strip() for x in row.strip("|").split("|")]
        c = cells[name.strip("`")]
        assert (int(robots), km, int(pairs)) == (c["robots"], f"{c['km']:.2f}", c["pairs"])

        def t(n: int, c: dict = c) -> float:
            return c["km"] * m / min(n, c["robots"]) + c["pairs"] * a / n

        cpu.append(c["km"] * m + c["pairs"] * a)
        assert 5 <= t(2) / 60 <= 8 and 1 <= t(10) / 60 <= 2 and t(100) < 40, name  # the sentence below the table
        assert shown == [f"{cpu[-1]:.0f}", f"{t(2) / 60:.1f}", f"{t(10) / 60:.1f}", f"{t(100) / 60:.1f}"], name
    said = re.search(r"adds one such cell: (\d+)-(\d+) CPU s", text)
    assert "5-8 min of wall time on 2 cores, 1-2 min on 10 Dask workers and under 40 s on 100" in text
    assert said is not None and (int(said[1]), int(said[2])) == (int(min(cpu) // 100 * 100), int(max(cpu) // 10 * 10))
