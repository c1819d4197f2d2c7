"""End-to-end benchmark: wall time and peak memory per stage of whole scenario runs.

Each scenario runs fresh in its own subprocess (so peak memory is the run's own); the
peak resident set size of every stage is read from ``/proc/self/status`` (VmHWM) after
resetting it through ``/proc/self/clear_refs`` at the stage's start (Linux), as every
``Experiment`` does (``stages.json`` keeps the same figures for any run).
Writes ``benchmarks/out/e2e.json``.
Run: ``python benchmarks/bench_e2e.py [scenario ...]`` (default: demo opposite_direction).
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "out" / "e2e.json"


def run_one(name: str) -> dict:
    """Run ``name`` fresh in this process; return its per-stage figures."""
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    sc = load_scenario(name)
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        res = Experiment(sc, Path(d) / name, fresh=True).run()
        total = time.perf_counter() - t0
    stages = {k: {"seconds": v["seconds"], "peak_rss_mb": v["peak_rss_mb"]} for k, v in res.timings.items()}
    return {
        "scenario": name,
        "total_seconds": total,
        "stages": stages,
        "peak_rss_mb": max((s["peak_rss_mb"] or 0.0) for s in stages.values()),
        "robots": len(sc.robots),
        "image": [sc.robots[0].camera.width, sc.robots[0].camera.height],
        "segments": res.map_stats.segments,
        "submaps": res.map_stats.submaps,
        "pairs": res.metrics.n_pairs,
        "summary": res.metrics_summary(),
    }


def main(argv: list[str]) -> None:
    if argv and argv[0] == "--child":
        print(json.dumps(run_one(argv[1]), default=float))
        return
    names = argv or ["demo", "opposite_direction"]
    results = []
    for name in names:
        proc = subprocess.run([sys.executable, __file__, "--child", name], capture_output=True, text=True,
                              env={**os.environ, "PYTHONWARNINGS": "ignore"})
        if proc.returncode != 0:
            print(proc.stderr[-2000:], file=sys.stderr)
            raise SystemExit(f"scenario {name} failed")
        res = json.loads(proc.stdout.strip().splitlines()[-1])
        results.append(res)
        print(f"{name}: {res['total_seconds']:.0f} s, peak {res['peak_rss_mb']:.0f} MB, "
              + ", ".join(f"{k} {v['seconds']:.1f} s" for k, v in res["stages"].items()))
    from roman_sim.core.atomic import write_json

    write_json(OUT, {"machine": {"cpus": os.cpu_count(), "python": platform.python_version()},
                     "load_average_at_end": os.getloadavg(), "runs": results})
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main(sys.argv[1:])
