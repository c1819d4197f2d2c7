"""``roman-sim demo``: CPU time per stage, the wall time it implies on 2 workers, and measured wall times.

On a shared machine wall time says more about the other jobs than about the code, so the
demo runs fresh in this process on the serial executor and every stage's CPU time
(``time.process_time``) is recorded, with each robot's share of the maps stage. The wall
time of ``roman-sim demo`` (a local pool of 2 workers on 2 free cores) is then estimated as

    max(start-up + world + world hand-off, CLI import + forkserver preload)
    + the slower robot's maps (the robots map in parallel) + the rest of the maps stage
    + (submaps + evaluation + report) / 2 (robots, pairs and figures spread over both cores)
    + posegraph + ate

where start-up is the CLI's imports (in its process), the forkserver preload is what a run's
pool imports and loads before it forks a worker (``roman_sim.runner.preload`` of the stages'
``worker_preload``;
the forkserver starts right after the CLI's own module, so it overlaps the CLI's imports
and the world), and the world hand-off is pickling the world for the workers and loading it
in one.

``--wall`` also runs ``roman-sim demo --fresh`` in a subprocess (``--repeats`` times; with
``--against PATH`` each run alternates with one of the checkout at PATH, e.g. the code before
a change unpacked with ``git archive``, recorded under ``against``) and records, per run, its
wall time, the wall time of each stage (the run's ``timings.json``),
the start-up and shutdown around the stages (wall time less the stages), the machine's load
average, and the CPU time of the whole process tree (the CLI, the forkserver and its
workers; sampled every 0.1 s with psutil when it is installed). Meaningful on a quiet
machine only; the fastest run is the figure.
Writes ``benchmarks/out/demo.json``.

Usage: python benchmarks/bench_demo.py [--wall [--repeats N] [--no-estimate] [--against PATH [--against-note TEXT]]]
       [--scenario demo] [--set key=value ...] [--label NAME] [--note TEXT]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from roman_sim.core.atomic import write_json

OUT = Path(__file__).resolve().parent / "out" / "demo.json"
PRELOAD = (
    "import time; t = time.process_time(); from roman_sim.runner.preload import preload; "
    "preload(('roman_sim.pipeline.stages:WORKER_PRELOAD',)); print(time.process_time() - t)"
)
HANDOFF = (
    "import time; from roman_sim.pipeline.scenario import load_scenario; "
    "from roman_sim.world import PickledWorld, generate; "
    "sc = load_scenario({name!r}); w = generate(sc.world.spec(), sc.seed); "
    "t = time.process_time(); p = PickledWorld.of(w); p.load(); print(time.process_time() - t)"
)


def _cpu(cmd: list[str]) -> float:
    """CPU seconds (user + system) of a child process run to completion."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _printed(code: str) -> float:
    """The last number a ``python -c code`` subprocess prints."""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    return float(out.split()[-1])


def stage_cpu(name: str, sets: list[str]) -> dict[str, Any]:
    """CPU seconds of every stage (and of each robot's mapping) of a fresh serial run of ``name``."""
    from roman_sim.core.records import to_json
    from roman_sim.pipeline import experiment
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.pipeline.stages import maps
    from roman_sim.runner.executor_base import ExecutorConfig

    stages: dict[str, float] = {}
    robots: dict[str, float] = {}
    run_stage, map_one = experiment.Experiment._run_stage, maps.map_one

    def timed_stage(self: Any, stage: Any, *args: Any) -> Any:
        t0 = time.process_time()
        try:
            return run_stage(self, stage, *args)
        finally:
            stages[stage.name] = time.process_time() - t0

    def timed_robot(ctx: Any, world: Any, cfg: Any) -> Any:
        t0 = time.process_time()
        try:
            return map_one(ctx, world, cfg)
        finally:
            robots[cfg.name] = time.process_time() - t0

    experiment.Experiment._run_stage = timed_stage  # type: ignore[method-assign]
    maps.map_one = timed_robot  # the serial maps stage calls it by this name
    try:
        with tempfile.TemporaryDirectory() as d:
            sc = load_scenario(name, sets)
            res = experiment.Experiment(sc, Path(d) / name, fresh=True, executor=ExecutorConfig(kind="serial")).run()
            summary = {"pairs": res.metrics.n_pairs, "segments": res.map_stats.segments}
            summary["summary"] = to_json(res.summary())
    finally:
        experiment.Experiment._run_stage, maps.map_one = run_stage, map_one
    return {"stages_cpu_s": stages, "robots_cpu_s": robots, **summary}


def estimate(name: str, sets: list[str]) -> dict[str, Any]:
    """Per-stage CPU, start-up costs and the 2-worker wall-time estimate (see the module docstring)."""
    py = sys.executable
    startup = _cpu([py, "-c", "import roman_sim.cli.run, roman_sim.pipeline.experiment, roman_sim.pipeline.stages"])
    cli = _cpu([py, "-c", "import roman_sim.cli.run"])
    preload = _printed(PRELOAD)
    handoff = _printed(HANDOFF.format(name=name))
    cpu = stage_cpu(name, sets)
    s, r = cpu["stages_cpu_s"], cpu["robots_cpu_s"]
    maps_wall = s["maps"] - sum(r.values()) + max(r.values()) if r else s.get("maps", 0.0)
    halved = ("submaps", "evaluation", "report")
    wall = max(startup + s.get("world", 0.0) + handoff, cli + preload) + maps_wall
    wall += sum(s.get(k, 0.0) for k in halved) / 2
    wall += sum(v for k, v in s.items() if k not in ("world", "maps", *halved))
    return {
        "scenario": name,
        "overrides": sets,
        "cli_startup_cpu_s": startup,
        "cli_import_cpu_s": cli,
        "forkserver_preload_cpu_s": preload,
        "world_handoff_cpu_s": handoff,
        **cpu,
        "total_cpu_s": startup + sum(s.values()),
        "wall_estimate_2_workers_s": wall,
    }


def _tree_cpu(pid: int, stop: threading.Event, out: dict[int, float]) -> None:
    """Until ``stop``: the CPU seconds of ``pid`` and every descendant, the last value seen of each."""
    import psutil

    while not stop.is_set():
        try:
            procs = [psutil.Process(pid), *psutil.Process(pid).children(recursive=True)]
        except psutil.NoSuchProcess:
            return
        for p in procs:
            try:
                t = p.cpu_times()
                out[p.pid] = t.user + t.system
            except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
                continue
        stop.wait(0.1)


def _imported_package(env: dict[str, str] | None, cwd: str) -> str:
    """Where a child started as ``measure_wall`` starts its run imports ``roman_sim`` from."""
    code = "import roman_sim; print(roman_sim.__file__)"
    out = subprocess.run([sys.executable, "-P", "-c", code], env=env, cwd=cwd, capture_output=True, text=True)
    return out.stdout.strip()


def measure_wall(name: str, tree: str | None = None) -> dict[str, Any]:
    """Wall time, per-stage wall times and process-tree CPU of ``roman-sim demo --fresh`` (or ``run NAME``).

    ``tree``: run the checkout at that path (its package first on ``PYTHONPATH``) instead of this one.
    """
    with tempfile.TemporaryDirectory() as d:
        run = Path(d) / "run"
        args = ["demo"] if name == "demo" else ["run", name]
        # -P and a neutral working directory: ``python -m`` would otherwise put the cwd (this
        # checkout, when run from its root) ahead of PYTHONPATH and run this tree both ways
        cmd = [sys.executable, "-P", "-m", "roman_sim.cli", *args, "--out", str(run), "--fresh"]
        env = {**os.environ, "PYTHONPATH": str(Path(tree).resolve())} if tree else None
        package = _imported_package(env, d)
        if tree and not package.startswith(str(Path(tree).resolve())):
            raise SystemExit(f"the child imports roman_sim from {package}, not from {tree}")
        load = [round(x, 2) for x in os.getloadavg()]
        seen: dict[int, float] = {}
        stop = threading.Event()
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, cwd=d)
        watcher = None
        try:
            import psutil  # noqa: F401  (optional: the process tree's CPU)

            watcher = threading.Thread(target=_tree_cpu, args=(proc.pid, stop, seen), daemon=True)
            watcher.start()
        except ImportError:
            pass
        code = proc.wait()
        wall = time.perf_counter() - t0
        stop.set()
        if watcher is not None:
            watcher.join()
        if code != 0:
            raise SystemExit(f"{' '.join(cmd)} failed with exit code {code}")
        timings = json.loads((run / "timings.json").read_text(encoding="utf-8"))["stages"]
        stages = {k: v["seconds"] for k, v in timings.items()}
        return {
            "wall_s": wall,
            "stages_wall_s": stages,
            "outside_stages_s": wall - sum(stages.values()),
            "alignment_wall_s": timings.get("evaluation", {}).get("pairs", {}).get("alignment_wall_s"),
            "cpu_s_process_tree": sum(seen.values()) if watcher is not None else None,
            "load_average_before": load,
            "package": package,
        }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="demo")
    ap.add_argument("--wall", action="store_true")
    ap.add_argument("--repeats", type=int, default=1, help="measured runs with --wall (the fastest is the figure)")
    ap.add_argument("--label", default="current")
    ap.add_argument("--note", default=None, help="what the figures are of (stored with them)")
    ap.add_argument("--set", dest="sets", action="append", default=[], help="scenario override, e.g. seed=3")
    ap.add_argument("--no-estimate", action="store_true", help="with --wall: skip the serial CPU estimate")
    ap.add_argument("--against", default=None, help="with --wall: alternate with runs of the checkout at this path")
    ap.add_argument("--against-note", default=None, help="what that checkout is (stored with its figures)")
    args = ap.parse_args()
    result = json.loads(OUT.read_text()) if OUT.is_file() else {}
    entry: dict[str, Any] = {} if args.no_estimate else estimate(args.scenario, args.sets)
    if args.note:
        entry["note"] = args.note
    if args.wall:
        runs, against = [], []
        for _ in range(max(1, args.repeats)):  # with --against, this tree and the other one alternately
            runs.append(measure_wall(args.scenario))
            if args.against:
                against.append(measure_wall(args.scenario, args.against))
        entry["measured_runs"] = runs
        entry["measured"] = min(runs, key=lambda m: m["wall_s"])
        if against:
            entry["against"] = {
                "tree": args.against_note or "another checkout",
                "measured_runs": against,
                "measured": min(against, key=lambda m: m["wall_s"]),
            }
    entry["load_average"] = [round(x, 2) for x in os.getloadavg()]
    result[args.label] = entry
    result["target_wall_s"] = 35.0
    write_json(OUT, result)
    print(json.dumps(entry, indent=1))


if __name__ == "__main__":
    main()
