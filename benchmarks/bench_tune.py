"""Cost and transfer of ``roman-sim tune`` on the ``quick`` suite; figures into ``benchmarks/out/tune.json``.

1. ``roman-sim tune quick`` with ROMAN's default grid (threshold 1-30, cos_min 0.8 / 0.85 /
   0.9): wall time, CPU time (this process and its waited-for children,
   ``resource.getrusage``; with ``--workers`` above 1 the pool's workers are not counted) and
   the load average before and after (the machine may be shared: wall time is then an upper
   bound, CPU time / 2 the wall time on 2 free cores if both were kept busy). Fresh by
   default (a private stage cache: every world is mapped); ``--cache DIR`` uses a stage cache
   that already holds the quick suite's maps (``ROMAN_SIM_CACHE=DIR roman-sim benchmark
   quick`` fills one), so only the alignments and the tune itself are timed.
2. The recommended setting on worlds the tune never saw: the quick suite's scene at seed
   ``CHECK_SEED`` in each level, run at exactly that setting (threshold and ``cos_min``);
   its pooled precision there against the target and against the held-out precision interval
   the tune stated (``held_out.precision_worlds``).

Run: ``python benchmarks/bench_tune.py [FOLDER] [--cache DIR] [--workers N]`` (default: a
temporary folder, removed after; one process).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import resource
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

from roman_sim.core.records import to_json
from roman_sim.evaluation.tune_result import TuneRecommended

OUT = Path(__file__).resolve().parent / "out" / "tune.json"
#: The seed of the worlds the recommended setting is checked on (the quick suite tunes on seed 0).
CHECK_SEED = 1


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _check(folder: Path, rec: TuneRecommended, target: float, executor: Any) -> dict[str, Any]:
    """The recommended setting, fixed, on the quick suite's worlds of ``CHECK_SEED``."""
    import numpy as np

    from roman_sim.benchmark.tune import TuneJob, config_outcomes
    from roman_sim.evaluation.transfer import counts, positives, world_bootstrap

    params = [f"threshold={rec.threshold}"] + [f"{k}={v}" for k, v in rec.values.items()]
    job = TuneJob("quick", "roman", folder, params, target, seeds=[CHECK_SEED], executor=executor)
    per_world, facts = job.collect()
    c = config_outcomes(job.grid.configs[0], per_world, facts)
    pos = positives(c.pairs, rec.threshold)
    tp, fp, rel = counts(c.pairs, pos)
    precision = tp / (tp + fp) if tp + fp else None
    return {
        "worlds": sorted(per_world),
        "hits": tp,
        "false_positives": fp,
        "n_relevant": rel,
        "precision": precision,
        "precision_worlds": world_bootstrap(c.pairs, pos, "precision", 2000, 0.95, 0) if tp + fp else None,
        "recall": tp / rel if rel else None,
        "pairs": int(len(c.pairs.score)),
        "positives_per_world": {w: int(np.count_nonzero(pos[c.pairs.world == w])) for w in sorted(per_world)},
    }


def _maps_reused(folder: Path) -> dict[str, bool]:
    """Per world of a tune folder, whether none of its alignments mapped (all took the maps from a cache)."""
    out: dict[str, bool] = {}
    for t in sorted(folder.glob("work/*/*/run/timings.json")):
        world = t.parents[2].name
        reused = bool(json.loads(t.read_text(encoding="utf-8"))["stages"].get("maps", {}).get("reused"))
        out[world] = out.get(world, True) and reused
    return out


def main() -> None:
    logging.basicConfig(level=logging.WARNING)
    from roman_sim.benchmark.tune import TuneJob
    from roman_sim.runner.executors import ExecutorConfig

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", nargs="?", type=Path, default=None)
    ap.add_argument("--cache", type=Path, default=None, help="a stage cache holding the quick suite's maps")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    keep = args.folder is not None
    root = args.folder if keep else Path(tempfile.mkdtemp(prefix="bench_tune_"))
    os.environ["ROMAN_SIM_CACHE"] = str(args.cache or root / "cache")  # default fresh: nothing mapped before
    ex = ExecutorConfig(kind="local", workers=args.workers) if args.workers > 1 else None
    load0, cpu0, t0 = _load(), _cpu(), time.perf_counter()
    job = TuneJob("quick", "roman", root / "tune", [], 0.9, executor=ex)
    result = job.run()
    wall, cpu = time.perf_counter() - t0, _cpu() - cpu0
    load1 = _load()
    rec = result.recommended
    check = _check(root / "check", rec, 0.9, ex) if rec is not None else None
    h = result.held_out
    ci = h.precision_worlds
    p = None if check is None else check["precision"]
    figures = {
        "suite": "quick",
        "method": "roman",
        "grid": {k: [min(v), max(v), len(v)] for k, v in result.parameters.items()},
        "alignments": len(job.grid.alignments()),
        "worlds": [w.id for w in result.worlds],
        "maps_reused": _maps_reused(root / "tune"),
        "workers": args.workers,
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
        "cpu_over_2_cores_s": round(cpu / 2, 1),
        "cores": os.cpu_count(),
        "load_before": load0,
        "load_after": load1,
        "note": "wall time on a shared machine is an upper bound; cpu_over_2_cores_s is the wall time on "
        "2 free cores if both were kept busy"
        + ("" if args.workers == 1 else f" (cpu_s leaves out the {args.workers} pool workers: not a bound)"),
        "recommended": None if rec is None else to_json(rec),
        "held_out": {
            k: getattr(h, k) for k in ("hits", "false_positives", "n_relevant", "precision", "precision_worlds")
        },
        "check_on_unseen_worlds": check,
        "reaches_target": None if p is None else p >= 0.9,
        "within_slack_of_target": None if p is None else p >= 0.9 - 0.05,
        "within_stated_interval": None if p is None or ci is None else ci[0] <= p <= ci[1],
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    print(json.dumps(figures, indent=2, sort_keys=True))
    if not keep:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
