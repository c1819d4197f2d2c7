"""Where the ambiguity knob puts a level: the measured ambiguity index of the standard suite's
crossing scene at a range of knob values, before anything is rendered.

For each knob value in ``KNOBS`` and each seed in ``SEEDS``, the standard suite's scene is planned
(``benchmark.scenes.build_crossing`` with ``ambiguity=True``: the drives, the submaps along them
and the pairs the evaluation will score, each with its place's ground-truth ambiguity, the mean
of ``world.ambiguity.place_ambiguity`` over the two true submap centres, as the evaluation stage
computes it). A level's index is the mean over its cross-robot pairs of that ambiguity (pairs
counted once, as the leaderboard's ``ambiguity_index``), pooled over the seeds; its spread over
seeds is reported as the smallest and largest per-seed index.

From the curve, the knob that puts a level at each ``TARGETS`` index is read off by linear
interpolation between the two measured knobs around it (the curve rises with the knob; a target
outside the measured range is reported as such, not extrapolated). The committed board's levels
(knob 0, 0.9, 0.95: measured indices 0.05, 0.45, 0.86 on their rendered pairs) are among the
knobs, so the planned index can be compared with the rendered one.

Writes ``benchmarks/out/levels.json``.

Usage: python benchmarks/measure_levels.py [--seeds N]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from roman_sim.benchmark.scenes import build_crossing
from roman_sim.benchmark.suites import SUITES
from roman_sim.core.atomic import write_text

KNOBS = [0.0, 0.5, 0.7, 0.8, 0.85, 0.875, 0.9, 0.925, 0.95, 0.96]
TARGETS = [0.05, 0.15, 0.3, 0.45, 0.85]
SEEDS = 4
OUT = Path(__file__).parent / "out" / "levels.json"


def level_index(knob: float, seeds: int) -> dict[str, object]:
    """The pooled and per-seed ambiguity index of the standard scene at ``knob``."""
    suite = SUITES.get("standard")
    scene = suite.scene.model_copy(update={"ambiguity": knob})
    per_seed, pooled = [], []
    for seed in range(seeds):
        plan = build_crossing(scene, seed, name=f"knob{knob:g}-s{seed}", ambiguity=True)
        vals = {(t.a, t.b): t.ambiguity for t in plan.truths if t.kind == "inter"}
        finite = [v for v in vals.values() if not math.isnan(v)]
        per_seed.append(float(np.mean(finite)) if finite else float("nan"))
        pooled.extend(finite)
    return {
        "knob": knob,
        "index": round(float(np.mean(pooled)), 4),
        "per_seed": [round(v, 4) for v in per_seed],
        "pairs": len(pooled),
    }


def knob_for(target: float, curve: list[dict[str, object]]) -> float | None:
    """The knob whose index is ``target`` by linear interpolation along ``curve`` (None outside it)."""
    xs = [float(c["knob"]) for c in curve]  # type: ignore[arg-type]
    ys = [float(c["index"]) for c in curve]  # type: ignore[arg-type]
    for (x0, y0), (x1, y1) in zip(zip(xs, ys), zip(xs[1:], ys[1:])):
        if min(y0, y1) <= target <= max(y0, y1) and y1 != y0:
            return round(x0 + (target - y0) * (x1 - x0) / (y1 - y0), 3)
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=SEEDS)
    args = ap.parse_args()
    t0, c0 = time.perf_counter(), time.process_time()
    curve = []
    for knob in KNOBS:
        row = level_index(knob, args.seeds)
        print(f"knob {knob:g}: index {row['index']} (seeds {row['per_seed']}, {row['pairs']} pairs)")
        curve.append(row)
    out = {
        "scene": "standard",
        "seeds": args.seeds,
        "curve": curve,
        "targets": {f"{t:g}": knob_for(t, curve) for t in TARGETS},
        "wall_s": round(time.perf_counter() - t0, 1),
        "cpu_s": round(time.process_time() - c0, 1),
    }
    write_text(OUT, json.dumps(out, indent=2) + "\n")
    print(json.dumps(out["targets"]))


if __name__ == "__main__":
    main()
