"""Cost of ``roman-sim benchmark``: the quick suite end to end, and a finished run of the standard suite.

Parts (each merges its figures into ``benchmarks/out/benchmark.json``; run with ``nice -n 10``):

* ``quick [WORKERS]``: the quick suite fresh: wall time, CPU time and the cells' stage
  times. WORKERS 1 (default) runs it in this process, so the CPU time is complete; with more
  the local pool's workers are children of its fork server, whose CPU time ``getrusage``
  does not see until it exits, so only the wall time is meaningful then.
* ``standard FOLDER WALL_S CPU_S PLANNING_CPU_S LOAD_LO,LOAD_HI LEVEL:CPU_S,...``: a finished
  ``roman-sim benchmark standard --out FOLDER`` run (its ``work/`` folder still there): its
  wall time, the CPU time of the job's processes, of its planning and of each level's cells
  (measured outside, e.g. by sampling ``ps``), the range of the load average during it; per cell its
  robots, kilometres, pairs, stage times, serial stages and alignment CPU; the Dask cost
  model's constants (``cost_constants``: s, m, a) and the model summed over the cells
  (``T(cell, N) = s + km * m / min(N, robots) + pairs * a / N``); whether the leaderboard's
  bounds were met.

CPU time counts every thread of this process and of its finished workers
(``resource.getrusage``); wall times on a machine others load are upper bounds, so the
load average is recorded before and after each part.
Run: ``python benchmarks/bench_benchmark.py quick`` (or ``quick 2``, ``standard ...``).
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


#: Stages a benchmark cell runs serially in the job's own process (the rest spreads over the workers).
SERIAL_STAGES = ("world", "submaps", "posegraph", "report")


def cost_constants(cells: dict[str, Any], cpu_s: float, planning_cpu_s: float) -> dict[str, float]:
    """The Dask cost model's constants from a run's cells (``standard`` below) and its measured CPU time.

    s: mean wall time of a cell's serial stages; a: alignment CPU (every method's timed pairs) per pair
    scored; m: the rest of the cells' CPU (mapping, with the evaluation's scoring and bookkeeping) per km.
    """
    serial = sum(c["serial_s"] for c in cells.values())
    align = sum(c["align_cpu_s"] for c in cells.values())
    pairs = sum(c["pairs"] for c in cells.values())
    km = sum(c["km"] for c in cells.values())
    return {
        "s": round(serial / len(cells), 1),
        "a": round(align / pairs, 4),
        "m": round((cpu_s - planning_cpu_s - serial - align) / km, 1),
    }


def model_s(c: dict[str, Any], k: dict[str, float], n: int) -> float:
    """T(cell, N) = s + km * m / min(N, robots) + pairs * a / N (seconds)."""
    return k["s"] + c["km"] * k["m"] / min(n, c["robots"]) + c["pairs"] * k["a"] / n


def standard(
    folder: Path, wall_s: float, cpu_s: float, planning_cpu_s: float, load: list[float], level_cpu: dict[str, float]
) -> None:
    """A finished standard run: wall and CPU time (measured outside; per level too, its cells run one after the
    other), per cell its size, stage times and alignment CPU, the cost model's constants, the leaderboard's bounds."""
    board = json.loads((folder / "leaderboard.json").read_text(encoding="utf-8"))
    plan = json.loads((folder / "plan.json").read_text(encoding="utf-8"))["cells"]
    stages = _stages(folder)
    cells = {}
    for cid, st in stages.items():
        scenario = json.loads((folder / "cells" / cid / "scenario.json").read_text(encoding="utf-8"))
        runtimes = json.loads((folder / "cells" / cid / "runtimes.json").read_text(encoding="utf-8"))
        cells[cid] = {
            "robots": len(scenario["robots"]),
            "km": plan[cid]["km"],
            "pairs": plan[cid]["pairs"],
            "serial_s": round(sum(st.get(k) or 0.0 for k in SERIAL_STAGES), 2),
            "align_cpu_s": round(sum((r["mean"] or 0.0) * r["n"] for r in runtimes.values()), 2),
        }
    k = cost_constants(cells, cpu_s, planning_cpu_s)
    _merge(
        "standard",
        {
            "wall_s": round(wall_s),
            "wall_min": round(wall_s / 60, 1),
            "cpu_s": round(cpu_s),
            "planning_cpu_s": round(planning_cpu_s),
            "level_cpu_s": {k: round(v) for k, v in level_cpu.items()},
            "load": load,
            "cells": cells,
            "stages_s": stages,
            "stages_total_s": round(sum(v or 0.0 for st in stages.values() for v in st.values())),
            "relevant": {e["name"]: [b["n_relevant"] for b in e["bins"]] for e in board["levels"]},
            "bound_met": board["bound_met"],
            "deployable_bound_met": board["deployable_bound_met"],
            "constants": k,
            "model_min": {
                str(n): round((planning_cpu_s / n + sum(model_s(c, k, n) for c in cells.values())) / 60, 1)
                for n in (2, 10, 100)
            },
            "note": "2 workers (local pool) on a 2-core machine shared with other jobs (load: the 1-minute load "
            "average's range during the run): wall times are upper bounds; cpu_s sums the CPU time of the job's "
            "processes (sampled every 10 s); stages_total_s sums the cells' stage wall times (planning not "
            "included); model_min is the cost model summed over the cells, planning spread over N",
        },
    )


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "quick"
    if what == "quick":
        quick(int(sys.argv[2]) if len(sys.argv) > 2 else 1)
    elif what == "standard":
        lo, hi = (float(x) for x in sys.argv[6].split(","))
        levels = {k: float(v) for k, v in (x.split(":") for x in sys.argv[7].split(","))}
        standard(Path(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5]), [lo, hi], levels)
    else:
        raise SystemExit(f"unknown part {what!r} (quick, standard)")
    print(json.dumps(json.loads(OUT.read_text(encoding="utf-8")), indent=2)[:3000])
