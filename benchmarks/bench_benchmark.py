"""Cost of ``roman-sim benchmark``: the quick suite end to end, and a part of the standard suite.

Parts (each merges its figures into ``benchmarks/out/benchmark.json``; run with ``nice -n 10``):

* ``quick [WORKERS]``: the quick suite fresh: wall time, CPU time and the cells' stage
  times. WORKERS 1 (default) runs it in this process, so the CPU time is complete; with more
  the local pool's workers are children of its fork server, whose CPU time ``getrusage``
  does not see until it exits, so only the wall time is meaningful then.
* ``plan``: the standard suite planned (no rendering): per cell its relevant pairs per
  heading bin, pairs and kilometres of trajectory, and the CPU time of planning.
* ``part [ROBOTS]``: one standard cell (level low, seed 0) with only ROBOTS robots (default
  6), every standard method, serially in this process: CPU time of the whole run, then of
  the evaluation again with the maps reused (``from_stage="evaluation"``), which separates
  mapping (m, CPU s per km) from alignment (a, CPU s per pair, report stage included).
* ``standard FOLDER WALL_S``: a finished ``roman-sim benchmark standard --out FOLDER`` run:
  its wall time WALL_S (measured outside, e.g. summed over resumed segments), its cells and
  their stage times, relevant pairs and whether every cell met the interval bound.
* ``estimate``: the standard suite's cost from ``plan`` and ``part``: CPU time
  ``sum(km * m + pairs * a)`` over the planned cells, its wall time on 2 free cores (CPU / 2),
  and on N Dask workers with the paper-scale cost model ``T(N) = km * m / min(N, robots) +
  pairs * a / N`` per cell.

CPU time counts every thread of this process and of its finished workers
(``resource.getrusage``); wall times on a machine others load are upper bounds, so the
load average is recorded before and after each part.
Run: ``python benchmarks/bench_benchmark.py quick`` (then ``plan``, ``part``, ``estimate``).
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

OUT = Path(__file__).resolve().parent / "out" / "benchmark.json"


def _cpu() -> float:
    """CPU seconds (user + system) of this process and of its waited-for children."""
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _merge(key: str, value: Any) -> None:
    data = json.loads(OUT.read_text(encoding="utf-8")) if OUT.is_file() else {}
    data[key] = value
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n", encoding="utf-8")


def _stages(folder: Path) -> dict[str, Any]:
    out = {}
    for cell in sorted((folder / "work").iterdir()):
        t = json.loads((cell / "timings.json").read_text(encoding="utf-8"))["stages"]
        out[cell.name] = {k: v.get("seconds") for k, v in t.items()}
    return out


def quick(workers: int = 1) -> None:
    from roman_sim.benchmark.run import BenchmarkJob
    from roman_sim.benchmark.suites import load_suite
    from roman_sim.runner.executors import ExecutorConfig

    folder = Path(tempfile.mkdtemp(prefix="bench-quick-"))
    load0, t0, c0 = _load(), time.perf_counter(), _cpu()
    ex = ExecutorConfig(kind="serial") if workers == 1 else ExecutorConfig(kind="local", workers=workers)
    outcome = BenchmarkJob(load_suite("quick"), folder, executor=ex).run()
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    board = json.loads((folder / "leaderboard.json").read_text(encoding="utf-8"))
    _merge(
        "quick" if workers == 1 else f"quick_{workers}_workers",
        {
            "workers": workers,
            "wall_s": round(wall, 1),
            "cpu_s": round(cpu, 1),
            "cpu_over_2_cores_s": round(cpu / 2, 1),
            "failures": outcome.failures,
            "stages_s": _stages(folder),
            "relevant": {e["name"]: [b["n_relevant"] for b in e["bins"]] for e in board["levels"] if e.get("bins")},
            "load_before": load0,
            "load_after": _load(),
            "note": "wall time on a shared machine is an upper bound; cpu_over_2_cores_s is the wall time on 2 "
            "free cores if both were kept busy",
        },
    )
    shutil.rmtree(folder, ignore_errors=True)


def plan() -> None:
    from roman_sim.benchmark.run import BenchmarkJob
    from roman_sim.benchmark.suites import load_suite
    from roman_sim.runner.executors import ExecutorConfig

    folder = Path(tempfile.mkdtemp(prefix="bench-plan-"))
    load0, c0 = _load(), _cpu()
    cells, plans = BenchmarkJob(load_suite("standard"), folder, executor=ExecutorConfig(kind="serial")).plan_only()
    cpu = _cpu() - c0
    rows = {}
    for c in cells:
        p = plans[c.id]
        data = json.loads((folder / "cells" / c.id / "scenario.json").read_text(encoding="utf-8"))
        rows[c.id] = {
            "relevant": p.relevant,
            "pairs": p.pairs,
            "submaps": p.submaps,
            "robots": len(data["robots"]),
            "km": p.km,
        }
    _merge(
        "standard_plan", {"cells": rows, "planning_cpu_s": round(cpu, 1), "load_before": load0, "load_after": _load()}
    )
    shutil.rmtree(folder, ignore_errors=True)


def part(robots: int) -> None:
    from roman_sim.benchmark.scenes import build_crossing
    from roman_sim.benchmark.suites import load_suite
    from roman_sim.pipeline.experiment import Experiment

    suite = load_suite("standard")
    scene = suite.scene_at("low", suite.methods, []).model_copy(update={"robots": robots})
    folder = Path(tempfile.mkdtemp(prefix="bench-part-"))
    load0, c0 = _load(), _cpu()
    sc = build_crossing(scene, 0, "standard-part").scenario
    c1 = _cpu()
    res = Experiment(sc, folder).run()
    c2 = _cpu()
    Experiment(sc, folder, from_stage="evaluation").run()
    c3 = _cpu()
    km, pairs = res.map_stats.trajectory_km, res.metrics.n_pairs
    full, evaluation = c2 - c1, c3 - c2
    _merge(
        "standard_part",
        {
            "robots": robots,
            "km": km,
            "pairs": pairs,
            "methods": suite.methods,
            "planning_cpu_s": round(c1 - c0, 1),
            "run_cpu_s": round(full, 1),
            "evaluation_again_cpu_s": round(evaluation, 1),
            "m_cpu_s_per_km": round((full - evaluation) / km, 1),
            "a_cpu_s_per_pair": round(evaluation / pairs, 4),
            "stages_wall_s": {k: v.get("seconds") for k, v in res.timings.items()},
            "load_before": load0,
            "load_after": _load(),
        },
    )
    shutil.rmtree(folder, ignore_errors=True)


def standard(folder: Path, wall_s: float) -> None:
    board = json.loads((folder / "leaderboard.json").read_text(encoding="utf-8"))
    stages = _stages(folder)
    _merge(
        "standard",
        {
            "wall_s": round(wall_s),
            "wall_min": round(wall_s / 60, 1),
            "cells": len(stages),
            "stages_s": stages,
            "stages_total_s": round(sum(v or 0.0 for st in stages.values() for v in st.values())),
            "relevant": {e["name"]: [b["n_relevant"] for b in e["bins"]] for e in board["levels"]},
            "bound_met": board["bound_met"],
            "load_after": _load(),
            "note": "2 workers (local pool) on a 2-core machine that also ran other jobs at times: an upper "
            "bound; stages_total_s sums the cells' stage wall times (planning not included)",
        },
    )


def estimate() -> None:
    data = json.loads(OUT.read_text(encoding="utf-8"))
    p, cells = data["standard_part"], data["standard_plan"]["cells"]
    m, a = p["m_cpu_s_per_km"], p["a_cpu_s_per_pair"]
    plan_cpu = data["standard_plan"]["planning_cpu_s"]
    cpu = plan_cpu + sum(c["km"] * m + c["pairs"] * a for c in cells.values())

    def dask(n: int) -> float:
        return plan_cpu / n + sum(c["km"] * m / min(n, c["robots"]) + c["pairs"] * a / n for c in cells.values())

    _merge(
        "standard_estimate",
        {
            "cells": len(cells),
            "km": round(sum(c["km"] for c in cells.values()), 2),
            "pairs": sum(c["pairs"] for c in cells.values()),
            "cpu_s": round(cpu),
            "wall_2_free_cores_min": round(cpu / 2 / 60, 1),
            "dask_min": {str(n): round(dask(n) / 60, 1) for n in (2, 10, 100)},
            "model": "T(N) = sum over cells of km * m / min(N, robots) + pairs * a / N (+ planning / N); m, a from "
            "standard_part",
        },
    )


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "quick"
    if what == "quick":
        quick(int(sys.argv[2]) if len(sys.argv) > 2 else 1)
    elif what == "plan":
        plan()
    elif what == "part":
        part(int(sys.argv[2]) if len(sys.argv) > 2 else 6)
    elif what == "standard":
        standard(Path(sys.argv[2]), float(sys.argv[3]))
    elif what == "estimate":
        estimate()
    else:
        raise SystemExit(f"unknown part {what!r} (quick, plan, part, standard, estimate)")
    print(json.dumps(json.loads(OUT.read_text(encoding="utf-8")), indent=2)[:3000])
