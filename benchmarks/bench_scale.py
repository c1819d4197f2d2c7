"""Scale benchmark: one run over several workers, paper-scale runs, Dask, pairs per second.

Parts (each merges its figures into ``benchmarks/out/scale.json``; run them one by one on a
shared machine, with ``nice -n 10``):

* ``demo [REPEATS]``: the demo fresh with the local pool, 1 and 2 workers interleaved
  REPEATS times (default 2) in this one benchmark run (target: 2 workers <= 0.6x the
  1-worker time, medians).
* ``paper SCENARIO [WORKERS]``: a paper-scale scenario end to end on the local pool
  (target <= 45 min); its run folder is ``results/work/SCENARIO``, the folder
  ``roman-sim reproduce --scenario SCENARIO`` uses, so the reference run reuses it.
* ``probe SCENARIO WORKERS LENGTH_M``: the same with every robot stopped after LENGTH_M metres
  (in ``results/work/SCENARIO-probe``): seconds per km per stage on the paper-scale worlds.
* ``dask SCENARIO [REPEATS]``: the scenario fresh on a loopback Dask ``LocalCluster`` with 1
  and 2 workers, interleaved REPEATS times (default 3; target speed-up >= 1.8x, medians).
* ``pairs SCENARIO``: from a finished run of SCENARIO, the evaluation again with all pairs and
  with submap gating: pairs per second per method, and recall per heading bin side by side.

The machine's load (``os.getloadavg``) is recorded before and after each part: figures
measured while others use the cores are noisy; compare ratios within one part.
Run: ``python benchmarks/bench_scale.py demo`` (see the parts above).
"""

from __future__ import annotations

import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

OUT = Path(__file__).resolve().parent / "out" / "scale.json"
WORK = Path("results/work")


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _run(
    name: str,
    run_dir: Path,
    executor: Any,
    overrides: list[str] | None = None,
    fresh: bool = True,
    from_stage: str | None = None,
) -> dict[str, Any]:
    from roman_sim.core.records import to_json
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    sc = load_scenario(name, overrides)
    t0 = time.perf_counter()
    res = Experiment(sc, run_dir, fresh=fresh, executor=executor, from_stage=from_stage).run()
    total = time.perf_counter() - t0
    s = res.summary()
    timings = to_json(res.timings.stages)
    km = res.map_stats.trajectory_km
    return {
        "scenario": name,
        "total_s": round(total, 1),
        "robots": len(sc.robots),
        "trajectory_km": km,
        "submaps": res.map_stats.submaps,
        "pairs": res.metrics.n_pairs,
        "stages_s": {k: v.get("seconds") for k, v in timings.items()},
        "pairs_timing": (timings.get("evaluation") or {}).get("pairs"),
        "alignment": {
            m: {k: v for k, v in a.items() if k != "per_pair_s"}
            for m, a in ((timings.get("evaluation") or {}).get("alignment") or {}).items()
        },
        "ate": {k: to_json(a) for k, a in s.ate.items()},
        "methods": {k: to_json(m) for k, m in s.methods.items()},
        "cross_robot": _cross_robot(res),
        "posegraph": _posegraph(res.run_dir),
    }


def _cross_robot(res: Any) -> dict[str, dict[str, str]]:
    """Per method: cross-robot max recall per coarse heading bin and overall, as ``0.52 (13/25)``."""
    from roman_sim.core.errors import EvaluationError

    out: dict[str, dict[str, str]] = {}
    for method in res.metrics.methods:
        cells = {}
        for label in ("0-60", "60-120", "120-180", None):
            try:
                st = res.metrics.stats(method, label, "inter")
            except EvaluationError:  # a bin the run has no pairs in
                continue
            cells[label or "all"] = (
                "n/a" if st.max_recall is None else f"{st.max_recall:.2f} ({st.max_hits}/{st.n_relevant})"
            )
        out[method] = cells
    return out


def _posegraph(run_dir: Path) -> Any:
    try:
        return json.loads((run_dir / "posegraph.json").read_text())
    except OSError:
        return None


def _one_vs_two(name: str, kind: str, repeats: int, overrides: list[str] | None = None) -> dict[str, Any]:
    """``name`` fresh with 1 and 2 workers, interleaved ``repeats`` times (the load of a shared machine
    drifts within minutes: the medians of interleaved runs compare like with like)."""
    import statistics

    from roman_sim.runner.executors import ExecutorConfig

    runs: dict[int, list[dict[str, Any]]] = {1: [], 2: []}
    with tempfile.TemporaryDirectory() as d:
        for r in range(repeats):
            for w in (1, 2) if r % 2 == 0 else (2, 1):
                runs[w].append(_run(name, Path(d) / f"w{w}r{r}", ExecutorConfig(kind=kind, workers=w), overrides))
                runs[w][-1]["load_after"] = _load()
    med = {w: statistics.median(x["total_s"] for x in rs) for w, rs in runs.items()}
    return {
        "scenario": name,
        "executor": kind,
        "repeats": repeats,
        "total_s": {str(w): [x["total_s"] for x in rs] for w, rs in runs.items()},
        "stages_s": {str(w): [x["stages_s"] for x in rs] for w, rs in runs.items()},
        "median_s": {str(w): m for w, m in med.items()},
        "ratio_2_over_1": round(med[2] / med[1], 3),
        "speedup_2_over_1": round(med[1] / med[2], 3),
        "example_run": runs[1][0],
    }


def part_demo(repeats: int) -> dict[str, Any]:
    return {**_one_vs_two("demo", "local", repeats), "target": "ratio_2_over_1 <= 0.6"}


def part_paper(name: str, workers: int) -> dict[str, Any]:
    from roman_sim.runner.executors import ExecutorConfig

    res = _run(name, WORK / name, ExecutorConfig(kind="local", workers=workers))
    res["workers"] = workers
    res["target_s"] = 45 * 60
    return res


def part_probe(name: str, workers: int, length_m: float) -> dict[str, Any]:
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.runner.executors import ExecutorConfig

    n = len(load_scenario(name).robots)
    ovr = [f"robots.{i}.max_length_m={length_m}" for i in range(n)]
    res = _run(name, WORK / f"{name}-probe", ExecutorConfig(kind="local", workers=workers), ovr)
    km = res["trajectory_km"] or 0.0
    res["workers"], res["length_m"] = workers, length_m
    res["seconds_per_km"] = {k: round(v / km, 1) for k, v in res["stages_s"].items() if v is not None and km}
    return res


def part_dask(name: str, repeats: int) -> dict[str, Any]:
    return {**_one_vs_two(name, "dask", repeats), "target": "speedup_2_over_1 >= 1.8"}


def part_pairs(name: str, workers: int) -> dict[str, Any]:
    """Evaluation only, from the finished run's maps and submaps: all pairs vs gated."""
    from roman_sim.runner.executors import ExecutorConfig

    src = WORK / name
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as d:
        for tag, ovr in (("all_pairs", []), ("gated", ["gating.enabled=true"])):
            run_dir = Path(d) / tag
            shutil.copytree(src, run_dir)
            r = _run(
                name, run_dir, ExecutorConfig(kind="local", workers=workers), ovr, fresh=False, from_stage="evaluation"
            )
            pt = r["pairs_timing"] or {}
            eval_s = r["stages_s"].get("evaluation") or 0.0
            wall = (pt.get("alignment_wall_s") or 0.0) + (pt.get("gating_s") or 0.0)
            out[tag] = {
                "candidates": pt.get("candidates"),
                "aligned": pt.get("aligned"),
                "gating_s": pt.get("gating_s"),
                "alignment_wall_s": pt.get("alignment_wall_s"),
                "evaluation_stage_s": eval_s,
                "candidate_pairs_per_s_all_methods": round((pt.get("candidates") or 0) / wall, 1) if wall else None,
                "per_method": {
                    m: {
                        "median_s": a.get("median"),
                        "mean_s": a.get("mean"),
                        "pairs_per_s_one_worker": round(1.0 / a["mean"], 1) if a.get("mean") else None,
                    }
                    for m, a in r["alignment"].items()
                },
                "cross_robot": r["cross_robot"],
                "ate": r["ate"],
            }
    from roman_sim.pipeline.scenario import load_scenario

    out["workers"] = workers
    out["top_k"] = load_scenario(name).gating.top_k
    return out


def main(argv: list[str]) -> None:
    part, rest = argv[0], argv[1:]
    before = _load()
    if part == "demo":
        key, fig = "demo_workers", part_demo(int(rest[0]) if rest else 2)
    elif part == "paper":
        key, fig = f"paper_{rest[0]}", part_paper(rest[0], int(rest[1]) if len(rest) > 1 else os.cpu_count() or 1)
    elif part == "probe":
        key, fig = f"probe_{rest[0]}", part_probe(rest[0], int(rest[1]), float(rest[2]))
    elif part == "dask":
        key, fig = f"dask_{rest[0]}", part_dask(rest[0], int(rest[1]) if len(rest) > 1 else 3)
    elif part == "pairs":
        key, fig = f"pairs_{rest[0]}", part_pairs(rest[0], int(rest[1]) if len(rest) > 1 else os.cpu_count() or 1)
    else:
        raise SystemExit(f"unknown part {part!r} (demo, paper, probe, dask, pairs)")
    fig["load_before"], fig["load_after"] = before, _load()
    data = json.loads(OUT.read_text()) if OUT.is_file() else {}
    data[key] = fig
    data["machine"] = {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(data, indent=2, sort_keys=True, default=float) + "\n")
    print(json.dumps({key: fig}, indent=1, default=float)[:4000])


if __name__ == "__main__":
    main(sys.argv[1:])
