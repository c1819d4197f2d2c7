"""``roman-sim demo``: CPU time per stage, and the wall time it implies on 2 workers.

On a shared machine wall time says more about the other jobs than about the code, so the
demo runs fresh in this process on the serial executor and every stage's CPU time
(``time.process_time``) is recorded, with each robot's share of the maps stage. The wall
time of ``roman-sim demo`` on 2 free cores is then estimated as

    start-up (imports, in the CLI process) + world + the slower robot's maps (the robots
    map in parallel) + submaps + evaluation / 2 (pairs spread over both workers) + posegraph
    + report + a worker's start-up (imports, world, numba's cached solver)

``--wall`` also runs ``roman-sim demo --fresh`` in a subprocess and records its wall time and
the CPU time of it and its workers (meaningful on a quiet machine only).
Writes ``benchmarks/out/demo.json``.

Usage: python benchmarks/bench_demo.py [--wall] [--scenario demo] [--set key=value ...] [--label NAME]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from roman_sim.core.atomic import write_json

OUT = Path(__file__).resolve().parent / "out" / "demo.json"
WORKER_START = (
    "import time; t = time.process_time(); "
    "from roman_sim.pipeline import tasks; from roman_sim.pipeline.scenario import load_scenario; "
    "from roman_sim.world import generate; sc = load_scenario({name!r}); generate(sc.world.spec(), sc.seed); "
    "from roman_sim.align import clipper; getattr(clipper, '_compiled', lambda: None)(); "
    "print(time.process_time() - t)"
)


def _cpu(cmd: list[str]) -> float:
    """CPU seconds (user + system) of a child process run to completion."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def stage_cpu(name: str, sets: list[str]) -> dict[str, Any]:
    """CPU seconds of every stage (and of each robot's mapping) of a fresh serial run of ``name``."""
    from roman_sim.pipeline import experiment
    from roman_sim.pipeline.executor_base import ExecutorConfig
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.pipeline.stages import maps

    stages: dict[str, float] = {}
    robots: dict[str, float] = {}
    run_stage, map_one = experiment.Experiment._run_stage, maps.map_one

    def timed_stage(self: Any, stage: Any, *args: Any) -> Any:
        t0 = time.process_time()
        try:
            return run_stage(self, stage, *args)
        finally:
            stages[stage.name] = time.process_time() - t0

    def timed_robot(ctx: Any, world: Any, cfg: Any, path: Any) -> Any:
        t0 = time.process_time()
        try:
            return map_one(ctx, world, cfg, path)
        finally:
            robots[cfg.name] = time.process_time() - t0

    experiment.Experiment._run_stage = timed_stage  # type: ignore[method-assign]
    maps.map_one = timed_robot  # the serial maps stage calls it by this name
    try:
        with tempfile.TemporaryDirectory() as d:
            sc = load_scenario(name, sets)
            res = experiment.Experiment(sc, Path(d) / name, fresh=True, executor=ExecutorConfig(kind="serial")).run()
            summary = {"pairs": res.metrics.n_pairs, "segments": res.map_stats.segments}
            summary["summary"] = res.metrics_summary()
    finally:
        experiment.Experiment._run_stage, maps.map_one = run_stage, map_one
    return {"stages_cpu_s": stages, "robots_cpu_s": robots, **summary}


def estimate(name: str, sets: list[str]) -> dict[str, Any]:
    """Per-stage CPU, start-up costs and the 2-worker wall-time estimate."""
    py = sys.executable
    startup = _cpu([py, "-c", "import roman_sim.cli.run, roman_sim.pipeline.experiment, roman_sim.pipeline.stages"])
    worker = float(
        subprocess.run(
            [py, "-c", WORKER_START.format(name=name)], capture_output=True, text=True, check=True
        ).stdout.split()[-1]
    )
    cpu = stage_cpu(name, sets)
    s, r = cpu["stages_cpu_s"], cpu["robots_cpu_s"]
    maps_wall = s["maps"] - sum(r.values()) + max(r.values()) if r else s.get("maps", 0.0)
    wall = startup + worker + maps_wall + s.get("evaluation", 0.0) / 2
    wall += sum(v for k, v in s.items() if k not in ("maps", "evaluation"))
    return {
        "scenario": name,
        "overrides": sets,
        "cli_startup_cpu_s": startup,
        "worker_startup_cpu_s": worker,
        **cpu,
        "total_cpu_s": startup + sum(s.values()),
        "wall_estimate_2_workers_s": wall,
    }


def measure_wall(name: str) -> dict[str, Any]:
    """Wall and CPU (with workers) of ``roman-sim demo --fresh`` (or ``run NAME``) in a subprocess."""
    with tempfile.TemporaryDirectory() as d:
        args = ["demo"] if name == "demo" else ["run", name]
        cmd = [sys.executable, "-m", "roman_sim.cli", *args, "--out", str(Path(d) / "run"), "--fresh"]
        t0 = time.perf_counter()
        cpu = _cpu(cmd)
        return {"wall_s": time.perf_counter() - t0, "cpu_s_with_workers": cpu}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="demo")
    ap.add_argument("--wall", action="store_true")
    ap.add_argument("--label", default="current")
    ap.add_argument("--set", dest="sets", action="append", default=[], help="scenario override, e.g. seed=3")
    args = ap.parse_args()
    result = json.loads(OUT.read_text()) if OUT.is_file() else {}
    entry = estimate(args.scenario, args.sets)
    if args.wall:
        entry["measured"] = measure_wall(args.scenario)
    entry["load_average"] = [round(x, 2) for x in os.getloadavg()]
    result[args.label] = entry
    result["target_wall_s"] = 35.0
    write_json(OUT, result)
    print(json.dumps(entry, indent=1))


if __name__ == "__main__":
    main()
