"""End-to-end benchmark: wall time and peak memory per stage of whole scenario runs.

Each scenario runs fresh in its own subprocess (so peak memory is the run's own); the
peak resident set size of every stage is read from ``/proc/self/status`` (VmHWM) after
resetting it through ``/proc/self/clear_refs`` at the stage's start (Linux), as every
``Experiment`` does (``stages.json`` keeps the same figures for any run).
Writes ``benchmarks/out/e2e.json``.
Run: ``python benchmarks/bench_e2e.py [scenario ...]`` (default: demo opposite_direction).

``--eval-ratio --baseline DIR [--repeats N]`` measures the demo's evaluation stage alone, with
every pair scored, against the same stage of another checkout of the package (``DIR`` holds
its ``roman_sim/``, e.g. ``git archive <commit> roman_sim | tar -x -C DIR``) run with the
40 m distance cap the demo used to have, on the same rendered maps and submaps, alternating
the two ``N`` times in one run so that both see the same machine load. Writes
``benchmarks/out/eval_ratio.json`` with the median wall and CPU seconds of each and their ratios
(the CPU ratio is the robust one on a shared machine), and the ratio of evaluation + report
stages (the plots moved from the evaluation stage to the report stage).
``--prepared RUN`` takes the maps and submaps from a finished demo run instead of running one.
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "out" / "e2e.json"


def run_one(name: str, overrides: list[str] | None = None) -> dict:
    """Run ``name`` (with dotted ``overrides``) fresh in this process; return its per-stage figures."""
    from roman_sim.core.records import to_json
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    sc = load_scenario(name, overrides or [])
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        res = Experiment(sc, Path(d) / name, fresh=True).run()
        total = time.perf_counter() - t0
    stages = {k: {"seconds": v.seconds, "peak_rss_mb": v.peak_rss_mb} for k, v in res.timings.stages.items()}
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
        "summary": to_json(res.summary()),
        "frontend": to_json(res.metrics.frontend),
    }


EVAL_CHILD = """
import json, shutil, sys, time
from pathlib import Path
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages import evaluation, report
src, dst, sets = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3:]
if dst.exists():
    shutil.rmtree(dst)
shutil.copytree(src, dst)
cpu = {}
def timed(cls, name):  # CPU seconds of the stage itself: robust to other processes' load
    run = cls.run
    def wrapped(self, *args, **kwargs):
        t0 = time.process_time()
        out = run(self, *args, **kwargs)
        cpu[name] = time.process_time() - t0
        return out
    cls.run = wrapped
timed(evaluation.EvaluationStage, "evaluation")
timed(report.ReportStage, "report")
res = Experiment(load_scenario("demo", sets), dst, from_stage="evaluation").run()
import roman_sim
print(json.dumps({"seconds": res.timings.stages["evaluation"].seconds, "cpu_seconds": cpu["evaluation"],
                  "report_seconds": res.timings.stages["report"].seconds, "report_cpu_seconds": cpu["report"],
                  "pairs": res.metrics.n_pairs, "package": roman_sim.__file__}))
"""


def _eval_child(tree: Path, prepared: Path, dst: Path, sets: list[str]) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "PYTHONWARNINGS": "ignore"}
    # -P and a neutral working directory: the child imports the package of ``tree``, never the one in the cwd
    proc = subprocess.run(
        [sys.executable, "-P", "-c", EVAL_CHILD, str(prepared), str(dst), *sets],
        capture_output=True,
        text=True,
        env=env,
        cwd=dst.parent,
    )
    if proc.returncode != 0:
        print(proc.stderr[-2000:], file=sys.stderr)
        raise SystemExit(f"evaluation stage failed in {tree}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def eval_ratio(baseline: Path, repeats: int, prepared_run: Path | None = None) -> dict:
    """Median evaluation-stage seconds: baseline (40 m cap) and this tree (every pair), alternated.

    ``prepared_run``: a finished demo run folder to take the maps and submaps from (else one is run).
    """
    import statistics

    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    here = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as d:
        prepared = Path(d) / "demo"
        if prepared_run is not None:
            shutil.copytree(prepared_run, prepared)
        Experiment(load_scenario("demo"), prepared).run()  # render, map and cut submaps once (or reuse them)
        runs: dict[str, list[dict]] = {"baseline": [], "current": []}
        for _ in range(repeats):
            runs["baseline"].append(_eval_child(baseline, prepared, Path(d) / "b", ["evaluation.max_pair_dist_m=40.0"]))
            runs["current"].append(_eval_child(here, prepared, Path(d) / "c", []))
    med = {k: statistics.median(r["seconds"] for r in v) for k, v in runs.items()}
    cpu = {k: statistics.median(r["cpu_seconds"] for r in v) for k, v in runs.items()}
    both = {k: statistics.median(r["seconds"] + r["report_seconds"] for r in v) for k, v in runs.items()}
    for k, tree in (("baseline", baseline), ("current", here)):
        if not all(Path(r["package"]).is_relative_to(tree) for r in runs[k]):
            raise SystemExit(f"the {k} runs imported another package: {runs[k][0]['package']}")
    return {
        "baseline_tree": str(baseline),
        "repeats": repeats,
        "runs": runs,
        "baseline_pairs": runs["baseline"][0]["pairs"],
        "current_pairs": runs["current"][0]["pairs"],
        "baseline_median_s": med["baseline"],
        "current_median_s": med["current"],
        "ratio": med["current"] / med["baseline"],
        "baseline_median_cpu_s": cpu["baseline"],
        "current_median_cpu_s": cpu["current"],
        "cpu_ratio": cpu["current"] / cpu["baseline"],
        "with_report_median_s": both,
        "with_report_ratio": both["current"] / both["baseline"],
        "load_average_at_end": os.getloadavg(),
    }


def main(argv: list[str]) -> None:
    if argv and argv[0] == "--child":
        print(json.dumps(run_one(argv[1], argv[2:]), default=float))
        return
    if argv and argv[0] == "--eval-ratio":
        if "--baseline" not in argv:
            raise SystemExit("--eval-ratio needs --baseline DIR (a checkout holding the roman_sim package to compare)")
        baseline = Path(argv[argv.index("--baseline") + 1]).resolve()
        repeats = int(argv[argv.index("--repeats") + 1]) if "--repeats" in argv else 2
        prepared = Path(argv[argv.index("--prepared") + 1]) if "--prepared" in argv else None
        from roman_sim.core.atomic import write_json

        res = eval_ratio(baseline, repeats, prepared)
        write_json(OUT.with_name("eval_ratio.json"), {"machine": {"cpus": os.cpu_count()}, **res})
        print(
            f"evaluation stage: baseline {res['baseline_median_s']:.1f} s ({res['baseline_median_cpu_s']:.1f} s CPU) "
            f"for {res['baseline_pairs']} pairs, current {res['current_median_s']:.1f} s "
            f"({res['current_median_cpu_s']:.1f} s CPU) for {res['current_pairs']} pairs: ratio {res['ratio']:.2f} "
            f"wall, {res['cpu_ratio']:.2f} CPU; with the report stage (where the plots are drawn now) "
            f"{res['with_report_ratio']:.2f} wall"
        )
        return
    names = argv or ["demo", "opposite_direction"]
    results = []
    for name in names:
        proc = subprocess.run(
            [sys.executable, __file__, "--child", name],
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONWARNINGS": "ignore"},
        )
        if proc.returncode != 0:
            print(proc.stderr[-2000:], file=sys.stderr)
            raise SystemExit(f"scenario {name} failed")
        res = json.loads(proc.stdout.strip().splitlines()[-1])
        results.append(res)
        print(
            f"{name}: {res['total_seconds']:.0f} s, peak {res['peak_rss_mb']:.0f} MB, "
            + ", ".join(f"{k} {v['seconds']:.1f} s" for k, v in res["stages"].items())
        )
    from roman_sim.core.atomic import write_json

    write_json(
        OUT,
        {
            "machine": {"cpus": os.cpu_count(), "python": platform.python_version()},
            "load_average_at_end": os.getloadavg(),
            "runs": results,
        },
    )
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main(sys.argv[1:])
