"""Alignment benchmark: per-pair runtime of every method, and the CLIPPER solver alone.

Pairs: synthetic submaps of 40 x 40 segments (20 shared objects, 20 outliers per side;
1600 putative all-to-all associations) with 768-d descriptors and a random 4-DoF pose.
Solver alone: the plain-distance consistency graph of n x n segments (n = 20, 40, 80, i.e.
400, 1600 and 6400 associations). Writes ``benchmarks/out/align.json``.
Run: ``python benchmarks/bench_align.py [--quick]``.
"""

from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

import numpy as np

from roman_sim.align import ALIGNERS, build_aligner
from roman_sim.align.affinity import build_affinity
from roman_sim.align.aligners import ClipperBaselineParams
from roman_sim.align.clipper import solve_clipper
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.atomic import write_json
from roman_sim.core.geometry import pose_4dof, pose_error
from roman_sim.core.seeding import child_rng

OUT = Path(__file__).resolve().parent / "out" / "align.json"


def _pairs(n_pairs: int) -> list[tuple]:
    rng = child_rng(0, "bench", "align")
    out = []
    for k in range(n_pairs):
        T = pose_4dof(*rng.uniform(-5, 5, 2), rng.uniform(-0.5, 0.5), rng.uniform(-np.pi, np.pi))
        a, b, _ = make_submap_pair(100 + k, 20, 20, 20, T_a_b=T, noise_m=0.05, descriptor_dim=768)
        out.append((a.public(), b.public(), T))
    return out


def _bench_method(name: str, pairs: list[tuple], repeats: int) -> dict:
    al = build_aligner(name)
    al.align(pairs[0][0], pairs[0][1])  # warm-up
    times, correct, n_assoc = [], 0, []
    for a, b, T in pairs:
        for _ in range(repeats):
            t0 = time.perf_counter()
            r = al.align(a, b)
            times.append(time.perf_counter() - t0)
        ok = r.ok and np.rad2deg(pose_error(r.T_a_b, T)[0]) <= 5 and pose_error(r.T_a_b, T)[1] <= 1
        correct += int(ok)
        n_assoc.append(r.n_associations)
    return {
        "median_ms": 1e3 * float(np.median(times)),
        "min_ms": 1e3 * float(np.min(times)),
        "runs": len(times),
        "correct_fraction": correct / len(pairs),
        "median_associations": float(np.median(n_assoc)),
    }


def _bench_solver(repeats: int) -> dict:
    out = {}
    for n in (20, 40, 80):
        a, b, _ = make_submap_pair(7, n // 2, n // 2, n // 2, noise_m=0.05, descriptor_dim=8)
        assoc = np.array([(i, j) for i in range(n) for j in range(n)])
        p = ClipperBaselineParams()
        t0 = time.perf_counter()
        M = build_affinity(a.centers, b.centers, assoc, None, p)
        t_build = time.perf_counter() - t0
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            sol = solve_clipper(M, p.solver)
            times.append(time.perf_counter() - t0)
        out[str(n * n)] = {
            "median_ms": 1e3 * float(np.median(times)),
            "min_ms": 1e3 * float(np.min(times)),
            "affinity_build_ms": 1e3 * t_build,
            "nnz": int(M.nnz),
            "iterations": sol.iterations,
            "selected": int(len(sol.selected)),
        }
    return out


def main(quick: bool = False) -> dict:
    """Run the benchmark and write the JSON figures."""
    n_pairs, reps = (3, 2) if quick else (8, 5)
    pairs = _pairs(n_pairs)
    methods = {}
    for name in ALIGNERS.names():
        slow = name.startswith("ransac1m")
        methods[name] = _bench_method(name, pairs[: 3 if slow else n_pairs], 1 if slow else reps)
    res = {
        "setup": "40 x 40 segments, 1600 putative associations, 768-d descriptors, 20 shared objects",
        "machine": platform.platform(),
        "python": platform.python_version(),
        "load_average": list(np.round(np.array(_loadavg()), 2)),
        "methods": methods,
        "solver_only": _bench_solver(3 if quick else 10),
        "ratio_ransac1m_over_roman": methods["ransac1m"]["median_ms"] / methods["roman"]["median_ms"],
    }
    write_json(OUT, res)
    return res


def _loadavg() -> tuple[float, float, float]:
    try:
        import os

        return os.getloadavg()
    except OSError:
        return (float("nan"),) * 3


if __name__ == "__main__":
    import json

    print(json.dumps(main(quick="--quick" in sys.argv), indent=2))
