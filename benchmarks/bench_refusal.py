"""Refusal benchmark: how long a second run into a busy results folder takes to say so.

This process holds the folder's lock (``hold_run_folder``) while ``roman-sim run smoke``
(``python -m roman_sim.cli``, a fresh interpreter each time) is started into it, ``n``
times per case: with ``--out`` (the lock is taken before anything else) and into the default
folder (the scenario is read first, to name the folder), each with the local pool asked for.
Every refusal must exit 1 with the one ``is in use by another run`` line. Reports the wall
time (median and max) and the CPU time of each refused process, with the load average at
the start, since on a shared machine the wall time follows the load. Writes
``benchmarks/out/refusal.json``.
Run: ``python benchmarks/bench_refusal.py [--quick]``.
"""

from __future__ import annotations

import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from roman_sim.core.atomic import write_json
from roman_sim.pipeline.folder_lock import hold_run_folder
from roman_sim.pipeline.scenario import default_run_dir, load_scenario

OUT = Path(__file__).resolve().parent / "out" / "refusal.json"
ROOT = Path(__file__).resolve().parents[1]


def _refusal(args: list[str], cwd: Path) -> tuple[float, float]:
    """Wall and CPU seconds of one refused ``roman-sim run smoke ARGS``."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(
        [sys.executable, "-m", "roman_sim.cli", "run", "smoke", *args], cwd=cwd, env=env, capture_output=True, text=True
    )
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 1 or "is in use by another run" not in res.stderr:
        raise SystemExit(f"not refused (exit {res.returncode}): {res.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _summary(times: list[tuple[float, float]]) -> dict:
    walls, cpus = [w for w, _ in times], [c for _, c in times]
    return {
        "n": len(times),
        "wall_s_median": round(statistics.median(walls), 3),
        "wall_s_max": round(max(walls), 3),
        "cpu_s_median": round(statistics.median(cpus), 3),
    }


def main(quick: bool = False) -> dict:
    """Run the benchmark and write its figures."""
    n = 3 if quick else 10
    out: dict = {"scenario": "smoke", "target_s": 2.0, "load_average_at_start": list(os.getloadavg()), "cases": {}}
    with tempfile.TemporaryDirectory(prefix="bench_refusal.") as tmp:
        cwd = Path(tmp)
        cases = {
            "out_given": (cwd / "busy", ["--out", str(cwd / "busy"), "--executor", "local"]),
            "default_folder": (cwd / default_run_dir(load_scenario("smoke")), ["--executor", "local"]),
        }
        for name, (folder, args) in cases.items():
            with hold_run_folder(folder):
                out["cases"][name] = _summary([_refusal(args, cwd) for _ in range(n)])
    out["machine"] = {
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
        "note": "wall time follows the machine's load (load_average_at_start); CPU time does not",
    }
    write_json(OUT, out)
    return out


if __name__ == "__main__":
    import json

    sys.stdout.write(json.dumps(main(quick="--quick" in sys.argv), indent=2) + "\n")
