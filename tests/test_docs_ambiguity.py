"""docs/scenarios.md's table of the ambiguity knob against the measured index, from the committed sweep."""

from __future__ import annotations

import csv
import gzip
import io
import json
from pathlib import Path

import numpy as np
import pytest
from committed_results import REFERENCE

ROOT = Path(__file__).resolve().parent.parent
SWEEP = REFERENCE / "ambiguity_sweep"
BEGIN, END = "<!-- ambiguity-knob:begin -->", "<!-- ambiguity-knob:end -->"


def knob_table() -> str:
    """The markdown table: per knob value, the measured index over the run's distinct pairs."""
    sweep = json.loads((SWEEP / "sweep.json").read_text(encoding="utf-8"))
    lines = [
        "| `ambiguity` knob | pairs | median index | 10th-90th percentile | range |",
        "|---|---|---|---|---|",
    ]
    for run in sorted(sweep["runs"], key=lambda r: r["params"]["world.overrides.ambiguity"]):
        text = gzip.decompress((SWEEP / run["run_id"] / "pairs.csv.gz").read_bytes()).decode("utf-8")
        index = {(r["a"], r["b"]): r["ambiguity"] for r in csv.DictReader(io.StringIO(text))}
        v = np.array([float(x) for x in index.values() if x != ""])
        p10, p90 = np.percentile(v, [10, 90])
        lines.append(
            f"| {run['params']['world.overrides.ambiguity']:g} | {len(v)} | {np.median(v):.2f} | "
            f"{p10:.2f}-{p90:.2f} | {v.min():.2f}-{v.max():.2f} |"
        )
    return "\n".join(lines)


@pytest.mark.skipif(not (SWEEP / "sweep.json").is_file(), reason="no committed ambiguity sweep")
def test_the_knob_table_is_the_committed_sweeps() -> None:
    text = (ROOT / "docs" / "scenarios.md").read_text(encoding="utf-8")
    block = text[text.index(BEGIN) + len(BEGIN) : text.index(END)].strip()
    assert block == knob_table()
