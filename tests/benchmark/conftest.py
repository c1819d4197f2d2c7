"""Shared by the benchmark tests: a scorer of benchmark folders by hand (standard library only)."""

from __future__ import annotations

import csv
import functools
import gzip
import io
import json
from collections.abc import Callable
from pathlib import Path

import pytest


def _rows(folder: Path) -> dict[tuple[str, str, str], list[tuple[int, bool, bool]]]:
    """(level, heading bin, method) -> (associations, relevant, correct) of every cross-robot pair.

    Read once per state of the folder's files (callers only read the result)."""
    files = sorted([folder / "benchmark.json", *folder.glob("cells/*/pairs.csv.gz")])
    return _read_rows(folder, tuple((str(f), f.stat().st_mtime_ns, f.stat().st_size) for f in files))


@functools.lru_cache(maxsize=4)
def _read_rows(folder: Path, stamp: tuple) -> dict[tuple[str, str, str], list[tuple[int, bool, bool]]]:
    """``_rows`` of ``folder`` as its files are at ``stamp`` (names, modification times, sizes)."""
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
    return rows


def by_hand_points(folder: Path) -> dict[tuple[str, str, str], tuple[int, int, int, int]]:
    """(level, heading bin, method) -> the max-recall point (hits, relevant, k, false positives), pooled
    over each level's cells: k is the highest threshold of 0..30 that keeps the most hits (relevant and
    correct at n_assoc >= k), the false positives are the pairs accepted at k that are not correct."""
    rows = _rows(folder)
    out = {}
    for key, rs in rows.items():
        hits = [sum(1 for n, rel, ok in rs if n >= k and rel and ok) for k in range(31)]
        best = max(hits)
        k = max(k for k in range(31) if hits[k] == best) if best else 0
        fp = sum(1 for n, _, ok in rs if n >= k and not ok)
        out[key] = (best, sum(1 for _, rel, _ in rs if rel), k, fp)
    return out


def by_hand_precision_90(folder: Path) -> dict[tuple[str, str, str], tuple[int, int | None, int]]:
    """(level, heading bin, method) -> (hits, k, false positives) at the smallest k of 0..30 whose precision
    hits / (hits + false positives) is at least 9/10 (a k that accepts nothing has no precision);
    (0, None, 0) when no k reaches it."""
    out: dict[tuple[str, str, str], tuple[int, int | None, int]] = {}
    for key, rs in _rows(folder).items():
        out[key] = (0, None, 0)
        for k in range(31):
            tp = sum(1 for n, rel, ok in rs if n >= k and rel and ok)
            fp = sum(1 for n, _, ok in rs if n >= k and not ok)
            if tp + fp > 0 and 10 * tp >= 9 * (tp + fp):
                out[key] = (tp, k, fp)
                break
    return out


def by_hand_scores(folder: Path) -> dict[tuple[str, str, str], tuple[int, int]]:
    """(level, heading bin, method) -> (max-recall hits, relevant), pooled over each level's cells."""
    return {key: point[:2] for key, point in by_hand_points(folder).items()}


@pytest.fixture(name="by_hand_points")
def _by_hand_points() -> Callable[[Path], dict[tuple[str, str, str], tuple[int, int, int, int]]]:
    return by_hand_points


@pytest.fixture(name="by_hand_precision_90")
def _by_hand_precision_90() -> Callable[[Path], dict[tuple[str, str, str], tuple[int, int | None, int]]]:
    return by_hand_precision_90


@pytest.fixture(name="by_hand")
def _by_hand() -> Callable[[Path], dict[tuple[str, str, str], tuple[int, int]]]:
    return by_hand_scores
