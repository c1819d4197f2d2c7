"""Evaluation benchmark: scoring and summary, result files, plots, map view.

Synthetic scored pairs (3 methods x 5000 pairs) and synthetic submaps (40 submaps of 40
segments, 200 points each) stand in for a long run. Writes ``benchmarks/out/evaluation.json``.
Run: ``python benchmarks/bench_evaluation.py``.
"""

from __future__ import annotations

import logging
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from roman_sim.align.base import AlignResult
from roman_sim.core.atomic import write_json
from roman_sim.core.geometry import make_T, pose_4dof, rot_x
from roman_sim.core.seeding import child_rng
from roman_sim.evaluation.assoc import shared_objects, true_correspondences
from roman_sim.evaluation.metrics import compute_metrics, score_pair
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.evaluation.results import read_pairs_csv, write_pairs_csv
from roman_sim.mapping.types import Submap, SubmapTruth
from roman_sim.report.mapview import map_view_png
from roman_sim.report.markdown import report_markdown
from roman_sim.report.plots import write_metric_plots

OUT = Path(__file__).resolve().parent / "out" / "evaluation.json"
N_PAIRS, METHODS = 5000, ("roman", "clipper", "ransac")


def _truths(rng: np.random.Generator) -> list[PairTruth]:
    out = []
    for i in range(N_PAIRS):
        x, y, yaw = rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(-np.pi, np.pi)
        d = float(np.hypot(x, y))
        ids_a, ids_b = rng.integers(0, 60, 40), rng.integers(0, 60, 40)
        out.append(
            PairTruth(
                f"a/{i}",
                f"b/{i}",
                "a",
                "b",
                i,
                i,
                pose_4dof(x, y, 0.0, yaw),
                d,
                abs(np.degrees(yaw)),
                rng.uniform(),
                rng.uniform(),
                d <= 10.0,
                "inter" if i % 4 else "intra",
                shared_objects(ids_a, ids_b),
                true_correspondences(ids_a, ids_b),
                ids_a,
                ids_b,
            )
        )
    return out


def _results(rng: np.random.Generator, truths: list[PairTruth], method: str) -> list[AlignResult]:
    out = []
    for t in truths:
        n = int(rng.integers(0, 25))
        err = make_T(rot_x(rng.normal(0, 0.05)), rng.normal(0, 0.5 if rng.uniform() < 0.6 else 5.0, 3))
        idx = np.stack([rng.integers(0, 40, n), rng.integers(0, 40, n)], 1).astype(np.int64)
        out.append(AlignResult(method, t.T_a_b_true @ err, idx, np.ones(n), float(rng.uniform(0.01, 0.2))))
    return out


def _submaps(rng: np.random.Generator, n_sub: int = 40, n_seg: int = 40, n_pts: int = 200) -> list[Submap]:
    subs = []
    for i in range(n_sub):
        centers = rng.uniform([-15, -15, 0], [15, 15, 3], (n_seg, 3))
        pts = [c + rng.normal(0, 0.4, (n_pts, 3)) for c in centers]
        T = pose_4dof(10.0 * i, 5.0 * np.sin(i / 4), 0.0, i / 10)
        subs.append(
            Submap(
                "r",
                i,
                float(i),
                T,
                np.arange(n_seg) + 1000 * i,
                centers,
                np.ones(n_seg),
                np.zeros((n_seg, 3)),
                np.zeros((n_seg, 4), np.float32),
                np.ones((n_seg, 3)),
                pts,
                SubmapTruth(T, np.arange(n_seg), np.ones(n_seg)),
            )
        )
    return subs


def _timed(fn, *args, **kw) -> tuple[object, float]:
    start = time.perf_counter()
    out = fn(*args, **kw)
    return out, time.perf_counter() - start


def main() -> dict:
    """Run the benchmark and write its JSON figures."""
    rng = child_rng(0, "bench", "evaluation")
    truths = _truths(rng)
    results = {m: _results(rng, truths, m) for m in METHODS}
    scores, t_score = _timed(lambda: [score_pair(t, r) for m in METHODS for t, r in zip(truths, results[m])])
    metrics, t_summary = _timed(compute_metrics, scores)
    fig: dict = {"n_scores": len(scores), "score_s": t_score, "summary_s": t_summary}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        _, fig["pairs_csv_write_s"] = _timed(write_pairs_csv, d / "pairs.csv", scores)
        fig["pairs_csv_kb"] = (d / "pairs.csv").stat().st_size / 1024
        back, fig["pairs_csv_read_s"] = _timed(read_pairs_csv, d / "pairs.csv")
        _, fig["summary_from_csv_s"] = _timed(compute_metrics, back)
        _, fig["metric_plots_s"] = _timed(write_metric_plots, metrics, d / "plots")
        _, fig["report_s"] = _timed(report_markdown, "bench", metrics)
    subs = _submaps(rng)
    _, fig["map_view_points_s"] = _timed(map_view_png, subs)
    no_pts = [Submap(**{**s.__dict__, "points": None}) for s in subs]
    _, fig["map_view_circles_s"] = _timed(map_view_png, no_pts)
    fig["map_view_points_in_map"] = sum(len(p) for s in subs for p in s.points or [])
    fig["map_view_points_drawn"] = sum(min(len(p), 100) for s in subs for p in s.points or [])
    out = {
        "figures": fig,
        "max_recall": {m: metrics.figure(m) for m in METHODS},
        "machine": {"python": platform.python_version(), "cpu": platform.processor() or platform.machine()},
    }
    write_json(OUT, out)
    return out


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING)
    res = main()
    for k, v in res["figures"].items():
        logging.getLogger("bench").warning("%s: %s", k, f"{v:.3f}" if isinstance(v, float) else v)
