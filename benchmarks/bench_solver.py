"""CLIPPER solver overhead: time per call over (gradient steps x one sparse mat-vec).

Problems: the plain-distance consistency graph of n x n synthetic segments (all-to-all
associations: n = 20, 40, 80 give 400, 1600 and 6400), as ``bench_align`` builds them. For
each, the CPU time (``time.process_time``) of one product with the solver's matrix (scipy's
CSR kernel, the diagonal removed: what the ascent multiplies by) and of whole
``solve_clipper`` calls are measured; ``overhead_ratio = call / (iterations x mat-vec)``
(1 would be a solver that only multiplies; target at most 3). Solvers: ``compiled`` (numba,
the default), ``numpy`` (the numpy path) and, with ``--baseline DIR`` (``DIR/roman_sim`` an
older checkout, e.g. ``git archive <commit> roman_sim | tar -x -C DIR``), that checkout's
solver loaded from its file. The solvers alternate ``--repeats`` times and each keeps its
fastest call, so all see the same machine load; all give the same selection (checked).
Writes ``benchmarks/out/solver.json``.

Usage: python benchmarks/bench_solver.py [--repeats 15] [--baseline DIR]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from roman_sim.align import clipper
from roman_sim.align.affinity import build_affinity
from roman_sim.align.aligners import ClipperBaselineParams
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.atomic import write_json

OUT = Path(__file__).resolve().parent / "out" / "solver.json"


def _problem(n: int) -> Any:
    a, b, _ = make_submap_pair(7, n // 2, n // 2, n // 2, noise_m=0.05, descriptor_dim=8)
    assoc = np.array([(i, j) for i in range(n) for j in range(n)])
    return build_affinity(a.centers, b.centers, assoc, None, ClipperBaselineParams())


def _matvec_seconds(M: Any, calls: int) -> float:
    """Mean CPU seconds of one product of the solver's matrix with a vector (best of 5 runs)."""
    A = clipper._prepare(M)
    pat = clipper._Pattern(A)
    v = np.random.default_rng(0).random(A.shape[0])
    best = np.inf
    for _ in range(5):
        t0 = time.process_time()
        for _ in range(calls):
            pat.mv(A.data, v)
        best = min(best, (time.process_time() - t0) / calls)
    return float(best)


def _load_baseline(root: Path) -> Callable[..., Any]:
    """``solve_clipper`` of an older checkout, loaded from its file next to this package."""
    spec = importlib.util.spec_from_file_location("clipper_baseline", root / "roman_sim" / "align" / "clipper.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module.solve_clipper


def run(repeats: int, baseline: Path | None) -> dict:
    """The figures of every problem size and solver."""
    p = ClipperBaselineParams().solver
    solvers: dict[str, Callable[..., Any]] = {"compiled": clipper.solve_clipper, "numpy": clipper.solve_clipper_numpy}
    if baseline is not None:
        solvers["baseline"] = _load_baseline(baseline)
    assert clipper._compiled() is not None, "numba could not build the compiled solver"
    out: dict[str, Any] = {}
    for n in (20, 40, 80):
        M = _problem(n)
        sols = {k: f(M, p) for k, f in solvers.items()}  # warm-up; and the same answer from all
        ref = sols["numpy"]
        assert all(np.array_equal(s.selected, ref.selected) for s in sols.values())
        best = {k: np.inf for k in solvers}
        for _ in range(repeats if n < 80 else max(2, repeats // 5)):
            for k, f in solvers.items():
                t0 = time.process_time()
                f(M, p)
                best[k] = min(best[k], time.process_time() - t0)
        mv = _matvec_seconds(M, {20: 400, 40: 100, 80: 5}[n])
        out[str(n * n)] = {
            "nnz": int(M.nnz),
            "iterations": ref.iterations,
            "selected": int(len(ref.selected)),
            "matvec_us": 1e6 * mv,
            **{f"{k}_ms": 1e3 * t for k, t in best.items()},
            **{f"{k}_overhead_ratio": t / (ref.iterations * mv) for k, t in best.items()},
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--baseline", type=Path, default=None)
    args = ap.parse_args()
    figures = run(args.repeats, args.baseline)
    result = {
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "load_average": [round(x, 2) for x in os.getloadavg()],
            "note": "2 cores shared with other jobs: CPU time, fastest of the alternated repeats",
        },
        "definition": "time per solve_clipper call / (gradient steps x CPU time of one sparse mat-vec)",
        "target_overhead_ratio": 3.0,
        "problems": figures,
    }
    write_json(OUT, result)
    for k, v in figures.items():
        print(k, {name: round(x, 3) if isinstance(x, float) else x for name, x in v.items()})


if __name__ == "__main__":
    main()
