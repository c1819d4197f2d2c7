"""Shared by the benchmark tests: a scorer of benchmark folders by hand (standard library only)."""

from __future__ import annotations

import csv
import gzip
import io
import json
from collections.abc import Callable
from pathlib import Path

import pytest


def by_hand_scores(folder: Path) -> dict[tuple[str, str, str], tuple[int, int]]:
    """(level, heading bin, method) -> (max-recall hits, relevant), pooled over each level's cells."""
    rec = json.loads((folder / "benchmark.json").read_text(encoding="utf-8"))
    edges = rec["heading_edges_deg"]
    rows: dict[tuple[str, str, str], list[tuple[int, bool, bool]]] = {}
    for c in rec["cells"]:
        if c["status"] != "ok":
            continue
        text = gzip.decompress((folder / "cells" / c["id"] / "pairs.csv.gz").read_bytes()).decode("utf-8")
        for r in csv.DictReader(io.StringIO(text)):
            if r["kind"] != "inter":
                continue
            h = float(r["heading_diff_deg"])
            i = next(j for j in range(len(edges) - 1) if h < edges[j + 1] or j == len(edges) - 2)
            label = f"{edges[i]:g}-{edges[i + 1]:g}"
            rel, ok = float(r["center_dist_m"]) <= 10.0, r["correct"] == "true"
            rows.setdefault((c["level"], label, r["method"]), []).append((int(r["n_assoc"]), rel, ok))
    out = {}
    for key, rs in rows.items():
        best = max(sum(1 for n, rel, ok in rs if n >= k and rel and ok) for k in range(31))
        out[key] = (best, sum(1 for _, rel, _ in rs if rel))
    return out


@pytest.fixture(name="by_hand")
def _by_hand() -> Callable[[Path], dict[tuple[str, str, str], tuple[int, int]]]:
    return by_hand_scores
