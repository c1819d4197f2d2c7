"""The operating points (``roman_sim.evaluation.operating_points``) of a committed reference run, re-derived
from its raw pairs table by a scorer of its own.

The scorer here reads ``pairs.csv.gz`` and ``config.yaml`` with the standard library and
PyYAML only: relevance from the true centre distance, correctness from the pose errors,
positives at k from the association counts, then each operating point by its definition.
It must agree with what the package computes from the same files (``metrics.json`` when
the run was written with the operating points, the verification's recomputation
otherwise), per method, overall and per heading bin, to the count.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import math

import pytest
import yaml
from committed_results import REFERENCE

from roman_sim.core.records import to_json
from roman_sim.report.recompute import recompute_metrics

RUN = REFERENCE / "opposite_direction"
Z95 = 1.959963984540054

pytestmark = pytest.mark.skipif(not (RUN / "pairs.csv.gz").is_file(), reason="no committed reference run")


def _config() -> dict:
    return yaml.safe_load((RUN / "config.yaml").read_text(encoding="utf-8"))


def _rows() -> list[dict[str, str]]:
    text = gzip.decompress((RUN / "pairs.csv.gz").read_bytes()).decode("utf-8")
    return [r for r in csv.DictReader(io.StringIO(text)) if r["kind"] == "inter"]


def _wilson(k: int, n: int) -> list[float] | None:
    if n == 0:
        return None
    p = k / n
    centre = (p + Z95**2 / (2 * n)) / (1 + Z95**2 / n)
    half = Z95 * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / (1 + Z95**2 / n)
    return [centre - half, centre + half]


def _point(k: int | None, tp: int, fp: int, n_rel: int) -> dict:
    return {"k": k, "hits": tp, "false_positives": fp, "n_relevant": n_rel, "recall_ci": _wilson(tp, n_rel)}


def _points(rows: list[dict[str, str]], ev: dict, acceptance_k: int) -> dict[str, dict]:
    """The four operating points of one method on ``rows``, by their definitions."""
    rel = [float(r["center_dist_m"]) <= ev["relevant_dist_m"] for r in rows]
    ok = [
        r["rot_err_deg"] != ""
        and float(r["rot_err_deg"]) <= ev["rot_tol_deg"]
        and float(r["trans_err_m"]) <= ev["trans_tol_m"]
        for r in rows
    ]
    n = [int(r["n_assoc"]) for r in rows]
    n_rel = sum(rel)

    def counts(k: int) -> tuple[int, int]:
        tp = sum(1 for i in range(len(rows)) if n[i] >= k and rel[i] and ok[i])
        fp = sum(1 for i in range(len(rows)) if n[i] >= k and not ok[i])
        return tp, fp

    sweep = [(k, *counts(k)) for k in range(ev["k_min"], ev["k_max"] + 1)]
    best = max(tp for _, tp, _ in sweep)
    at_best = [s for s in sweep if s[1] == best]
    k, tp, fp = at_best[-1] if best else sweep[0]
    out = {"max_recall": _point(k, tp, fp, n_rel)}
    for name, (num, den) in {"precision_90": (9, 10), "precision_100": (1, 1)}.items():
        hit = [s for s in sweep if s[1] + s[2] > 0 and s[1] * den >= num * (s[1] + s[2])]
        out[name] = _point(*hit[0], n_rel) if hit else _point(None, 0, 0, n_rel)
    out["acceptance"] = _point(acceptance_k, *counts(acceptance_k), n_rel)
    return out


def _package_points() -> dict:
    stored = json.loads((RUN / "metrics.json").read_text(encoding="utf-8"))
    if "acceptance_k" in stored:
        return stored
    metrics, _ = recompute_metrics(RUN, "pairs.csv.gz")
    return json.loads(json.dumps(to_json(metrics)))


def test_operating_points_follow_from_the_pairs_table():
    cfg = _config()
    ev = {"relevant_dist_m": 10.0, "rot_tol_deg": 5.0, "trans_tol_m": 1.0, "k_min": 0, "k_max": 30}
    ev.update({k: v for k, v in (cfg.get("evaluation") or {}).items() if k in ev})
    assert (cfg.get("evaluation") or {}).get("relevance", "distance") == "distance"
    acceptance_k = int((cfg.get("posegraph") or {}).get("lc_association_thresh", 4))
    edges = (cfg.get("evaluation") or {}).get("heading_bins_deg", [0.0, 60.0, 120.0, 180.0])
    package = _package_points()
    assert package["acceptance_k"] == acceptance_k
    rows = _rows()
    methods = sorted({r["method"] for r in rows})
    assert methods == sorted(package["methods"])
    compared = 0
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        sets = {"overall": (mine, package["methods"][m]["inter"])}
        for i, b in enumerate(package["methods"][m]["inter"]["heading_bins"]):
            last = i == len(edges) - 2
            in_bin = [
                r
                for r in mine
                if edges[i] <= float(r["heading_diff_deg"]) < edges[i + 1]
                or (last and float(r["heading_diff_deg"]) == edges[-1])
            ]
            sets[b["label"]] = (in_bin, b)
        for where, (subset, theirs) in sets.items():
            expect = _points(subset, ev, acceptance_k)
            for name, p in expect.items():
                got = theirs["operating_points"][name]
                assert {k: got[k] for k in ("k", "hits", "false_positives", "n_relevant")} == {
                    k: p[k] for k in ("k", "hits", "false_positives", "n_relevant")
                }, (m, where, name)
                assert (got["recall_ci"] is None) == (p["recall_ci"] is None), (m, where, name)
                if p["recall_ci"] is not None:
                    assert got["recall_ci"] == pytest.approx(p["recall_ci"], abs=1e-9), (m, where, name)
                compared += 1
    assert compared == len(methods) * 4 * (len(edges) - 1 + 1)
