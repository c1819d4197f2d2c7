"""Cost and transfer of ``roman-sim tune`` on the ``quick`` suite; figures into ``benchmarks/out/tune.json``.

1. ``roman-sim tune quick --rule point`` (the script's rule unless ``--rule``) with ROMAN's
   default grid (threshold 1-30, cos_min 0.8 / 0.85 / 0.9): wall time, CPU time and the load
   average before and after. CPU time counts this process and its waited-for children
   (``resource.getrusage``); with ``--workers`` above 1 the pool's workers are forked by
   multiprocessing's forkserver, not by this process, so the process tree is sampled every half
   second (``psutil``) and their last seen CPU time added (a lower bound: a worker's last half
   second may be missed). The default, one worker, runs everything in this process: its CPU
   time is exact. The machine may be shared: wall time is then an upper bound; CPU time / 2 is
   the wall time on 2 free cores if both were kept busy, CPU time the wall time on one. Fresh
   by default (a private stage cache: every world is mapped); ``--cache DIR`` uses a stage
   cache that already holds the quick suite's maps (``ROMAN_SIM_CACHE=DIR roman-sim benchmark
   quick`` fills one), so only the alignments and the tune itself are timed.
2. The recommended setting on worlds the tune never saw: the quick suite's scene at each seed
   of ``CHECK_SEEDS`` in each level (one world is one draw: several per level), run at exactly
   that setting (threshold and ``cos_min``). Per world its precision (with the Wilson interval
   of its counts) against the target and against the interval the tune stated for one new
   world (``held_out.precision_new_world``); per seed the precision pooled over the levels
   against the pooled held-out interval the tune stated (``held_out.precision_worlds``, the
   same statistic: one world per level); per level and over every unseen world the pooled
   precision. ``--check-cache DIR``: a stage cache for these worlds (not timed).

3. ``--level NAME``: the same, tuned on one level's worlds only (``roman-sim tune quick
   --level NAME --seeds LO:HI``, ``--seeds``, default 0:4) and checked on that level's worlds
   of ``--check-seeds`` (default 4, 5, 6), none of which the tune saw. The figures go into the
   file's ``level_tunes`` under the level; the figures of the all-level tune are kept as they are.

4. ``--rule lower`` or ``--rule world`` (with ``--level``): the tune recommends by the lower end
   of each setting's one-new-world precision interval, or by the share of new worlds the spread of
   the worlds' precisions puts within 0.05 of the target (``roman-sim tune --rule``); each unseen
   world's hits are also checked against the 95 % interval that spread gives a world accepting as
   many pairs (``inside_spread_interval``). The point rule's setting is
   scored from the same alignments (``tune_point/``: the work folder copied, nothing re-aligned)
   and checked on the same unseen worlds, so the two rules are compared like with like. The
   figures go into the file's ``rule_tunes`` under ``<level>-<rule>``; the other keys are kept.
   ``--reuse DIR``: the FOLDER of a finished run of this script on the same level and seeds; its
   ``tune/work/`` and ``cache/`` are copied in first (its alignments read back, not re-run; the
   cost figures then time the reading back only; ``alignments_read_back`` says so). The file also
   records, over every setting, the highest lowest-world Wilson lower end
   (``best_lowest_world_wilson``): no setting's one-new-world lower end exceeds it.

Run: ``python benchmarks/bench_tune.py [FOLDER] [--cache DIR] [--check-cache DIR] [--workers N]
[--level NAME [--seeds LO:HI] [--check-seeds A,B,C] [--rule lower|world [--reuse DIR]]]`` (default: a
temporary folder, removed after; one worker).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import resource
import shutil
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from roman_sim.benchmark.tune_choice import RULES
from roman_sim.benchmark.tune_result import TuneHeldOut, TuneRecommended
from roman_sim.core.records import to_json

OUT = Path(__file__).resolve().parent / "out" / "tune.json"
#: The seeds of the worlds the recommended setting is checked on (the quick suite tunes on seed 0).
CHECK_SEEDS = [1, 2, 3]


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


class TreeCpu:
    """Samples the CPU time of this process's descendants that it does not wait for (pool workers)."""

    def __init__(self, every_s: float = 0.5) -> None:
        self.every_s, self.seen = every_s, {}  # type: ignore[var-annotated]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        import psutil

        me = psutil.Process()
        while not self._stop.is_set():
            for p in me.children(recursive=True):
                try:
                    if p.ppid() == me.pid:  # a direct child: counted by RUSAGE_CHILDREN once waited for
                        continue
                    t = p.cpu_times()
                    self.seen[(p.pid, p.create_time())] = t.user + t.system
                except psutil.Error:
                    continue
            self._stop.wait(self.every_s)

    def __enter__(self) -> TreeCpu:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def total(self) -> float:
        """CPU seconds of every sampled descendant, at its last sample."""
        return float(sum(self.seen.values()))


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _inside(v: float | None, ci: list[float] | tuple[float, float] | None) -> bool | None:
    return None if v is None or ci is None else bool(ci[0] <= v <= ci[1])


def _ratio(tp: int, fp: int) -> float | None:
    return tp / (tp + fp) if tp + fp else None


def _check(
    folder: Path,
    rec: TuneRecommended,
    h: TuneHeldOut,
    target: float,
    executor: Any,
    level: str | None = None,
    seeds: list[int] = CHECK_SEEDS,
) -> dict[str, Any]:
    """The recommended setting, fixed, on the quick suite's worlds of ``seeds`` (of ``level`` only when given)."""
    from roman_sim.benchmark.transfer import PRECISION_SLACK, counts, positives, world_bootstrap, world_precisions
    from roman_sim.benchmark.tune import TuneJob, config_outcomes
    from roman_sim.benchmark.world_spread import WorldSpread
    from roman_sim.evaluation.intervals import wilson

    sp = rec.spread
    spread = None if sp is None else WorldSpread(sp.a, sp.b, sp.worlds)

    def in_spread(p: Any) -> bool | None:
        """Whether a world's hits lie in the 95 % interval the spread gives a world accepting as many pairs."""
        n = p.hits + p.false_positives
        if spread is None or n == 0:
            return None
        lo, hi = spread.hits_interval(n)
        return bool(lo <= p.hits <= hi)

    params = [f"threshold={rec.threshold}"] + [f"{k}={v}" for k, v in rec.values.items()]
    job = TuneJob("quick", "roman", folder, params, target, seeds=seeds, executor=executor, level=level, rule="point")
    per_world, facts = job.collect()
    c = config_outcomes(job.grid.configs[0], per_world, facts)
    pos = positives(c.pairs, rec.threshold)
    tp, fp, rel = counts(c.pairs, pos)
    worlds = {
        p.world: {
            "hits": p.hits,
            "false_positives": p.false_positives,
            "precision": p.precision,
            "precision_wilson": None if p.wilson is None else list(p.wilson),
            "inside_new_world_interval": _inside(p.precision, h.precision_new_world),
            "reaches_target": None if p.precision is None else p.precision >= target,
            "within_slack": None if p.precision is None else p.precision >= target - PRECISION_SLACK,
            "inside_spread_interval": in_spread(p),
        }
        for p in world_precisions(c.pairs, pos)
    }

    def pooled(keep: list[str]) -> dict[str, Any]:
        a, b = sum(worlds[w]["hits"] for w in keep), sum(worlds[w]["false_positives"] for w in keep)
        return {"worlds": keep, "hits": a, "false_positives": b, "precision": _ratio(a, b)}

    levels = sorted({w.rsplit("-s", 1)[0] for w in worlds})
    per_level = {lv: pooled([w for w in worlds if w.rsplit("-s", 1)[0] == lv]) for lv in levels}
    per_seed = {}
    for s in seeds:
        d = pooled([w for w in worlds if w.endswith(f"-s{s}")])
        d["inside_pooled_interval"] = _inside(d["precision"], h.precision_worlds)
        per_seed[f"s{s}"] = d
    inside = [v["inside_new_world_interval"] for v in worlds.values() if v["inside_new_world_interval"] is not None]
    in_sp = [v["inside_spread_interval"] for v in worlds.values() if v["inside_spread_interval"] is not None]
    accepting = [v for v in worlds.values() if v["precision"] is not None]
    seeds_inside = [v["inside_pooled_interval"] for v in per_seed.values() if v["inside_pooled_interval"] is not None]
    return {
        "seeds": seeds,
        "hits": tp,
        "false_positives": fp,
        "n_relevant": rel,
        "pairs": int(len(c.pairs.score)),
        "precision": _ratio(tp, fp),
        "precision_wilson": wilson(tp, tp + fp) if tp + fp else None,
        "precision_worlds": world_bootstrap(c.pairs, pos, "precision", 2000, 0.95, 0) if tp + fp else None,
        "recall": tp / rel if rel else None,
        "per_world": worlds,
        "per_level": per_level,
        "per_seed": per_seed,
        "worlds_inside_new_world_interval": [sum(inside), len(inside)],
        "seeds_inside_pooled_interval": [sum(seeds_inside), len(seeds_inside)],
        "worlds_reaching_target": [sum(1 for v in worlds.values() if v["reaches_target"]), len(worlds)],
        "worlds_within_slack": [sum(1 for v in accepting if v["within_slack"]), len(accepting)],
        "worlds_inside_spread_interval": [sum(in_sp), len(in_sp)],
        "spread_share_at_target": None if sp is None else sp.share_at_target,
        "spread_share_within_slack": None if sp is None else sp.share_within_slack,
    }


def _maps_reused(folder: Path) -> dict[str, bool]:
    """Per world of a tune folder, whether none of its alignments mapped (all took the maps from a cache)."""
    out: dict[str, bool] = {}
    for t in sorted(folder.glob("work/*/*/run/timings.json")):
        world = t.parents[2].name
        reused = bool(json.loads(t.read_text(encoding="utf-8"))["stages"].get("maps", {}).get("reused"))
        out[world] = out.get(world, True) and reused
    return out


def _best_lowest_world_wilson(job: Any) -> dict[str, Any]:
    """Over every setting of the tune (config and threshold), the one whose lowest world Wilson lower end is
    highest: an upper bound of any setting's one-new-world lower end (the hull's lower end is at most it)."""
    from roman_sim.benchmark.transfer import positives, world_precisions
    from roman_sim.benchmark.tune import config_outcomes

    per_world, facts = job.collect()
    best: dict[str, Any] = {"value": -1.0}
    for cfg in job.grid.configs:
        pairs = config_outcomes(cfg, per_world, facts).pairs
        for k in job.grid.thresholds:
            ws = world_precisions(pairs, positives(pairs, k))
            low = min(0.0 if p.wilson is None else p.wilson[0] for p in ws)
            if low > best["value"]:
                best = {"value": low, "values": cfg.values(), "threshold": int(k)}
    return best


def _point_rule(
    root: Path, job: Any, seeds: list[int] | None, check_seeds: list[int], args: Any, ex: Any
) -> dict[str, Any]:
    """The point rule on the same alignments (work folder copied: nothing re-aligned), its recommended setting
    checked on the same unseen worlds."""
    from roman_sim.benchmark.tune import TuneJob

    folder = root / "tune_point"
    if not (folder / "work").exists():
        shutil.copytree(root / "tune" / "work", folder / "work")
    pj = TuneJob("quick", "roman", folder, [], 0.9, seeds=seeds, executor=ex, level=args.level, rule="point")
    res = pj.run()
    rec, h = res.recommended, res.held_out
    check = _check(root / "check_point", rec, h, 0.9, ex, args.level, check_seeds) if rec is not None else None
    return {
        "recommended": None if rec is None else to_json(rec),
        "held_out": {
            k: to_json(getattr(h, k))
            for k in ("hits", "false_positives", "n_relevant", "precision", "precision_worlds", "per_world")
        }
        | {"precision_new_world": to_json(h.precision_new_world), "chosen": to_json(h.chosen)},
        "check_on_unseen_worlds": check,
    }


def main() -> None:
    logging.basicConfig(level=logging.WARNING)
    from roman_sim.benchmark.tune import TuneJob
    from roman_sim.runner.executors import ExecutorConfig

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", nargs="?", type=Path, default=None)
    ap.add_argument("--cache", type=Path, default=None, help="a stage cache holding the quick suite's maps")
    ap.add_argument("--check-cache", type=Path, default=None, help="a stage cache for the unseen worlds (not timed)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--level", default=None, help="tune on this level of quick only (see the docstring)")
    ap.add_argument("--seeds", default="0:4", help="with --level: the tune's seeds, LO:HI or A,B,C")
    ap.add_argument("--check-seeds", default="4,5,6", help="with --level: the unseen worlds' seeds")
    ap.add_argument("--rule", default="point", choices=list(RULES), help="with --level: the rule")
    ap.add_argument("--reuse", type=Path, default=None, help="with --rule lower/world: a finished FOLDER to copy")
    args = ap.parse_args()
    if args.rule != "point" and not args.level:
        ap.error("--rule: takes --level (the rule comparison is per level)")
    from roman_sim.cli.tune import _seeds

    tune_seeds = _seeds(args.seeds) if args.level else None
    check_seeds = (_seeds(args.check_seeds) or []) if args.level else CHECK_SEEDS
    if args.level and set(tune_seeds or []) & set(check_seeds):
        ap.error("--check-seeds: the unseen worlds must not be tuned on (they share seeds with --seeds)")
    keep = args.folder is not None
    root = args.folder if keep else Path(tempfile.mkdtemp(prefix="bench_tune_"))
    if args.reuse is not None:
        for sub in ("tune/work", "cache"):
            if (args.reuse / sub).is_dir() and not (root / sub).exists():
                shutil.copytree(args.reuse / sub, root / sub)
    os.environ["ROMAN_SIM_CACHE"] = str(args.cache or root / "cache")  # default fresh: nothing mapped before
    ex = ExecutorConfig(kind="local", workers=args.workers) if args.workers > 1 else None
    load0, cpu0, t0 = _load(), _cpu(), time.perf_counter()
    with TreeCpu() as tree:
        job = TuneJob(
            "quick", "roman", root / "tune", [], 0.9, seeds=tune_seeds, executor=ex, level=args.level, rule=args.rule
        )
        result = job.run()
    wall, cpu = time.perf_counter() - t0, _cpu() - cpu0 + tree.total()
    load1 = _load()
    rec, h = result.recommended, result.held_out
    if args.check_cache is not None:
        os.environ["ROMAN_SIM_CACHE"] = str(args.check_cache)
    check = _check(root / "check", rec, h, 0.9, ex, args.level, check_seeds) if rec is not None else None
    p = None if check is None else check["precision"]
    figures: dict[str, Any] = {
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
        + ("" if args.workers == 1 else f" (the {args.workers} pool workers sampled every 0.5 s: a lower bound)"),
        "recommended": None if rec is None else to_json(rec),
        "held_out": {
            k: to_json(getattr(h, k))
            for k in (
                "hits",
                "false_positives",
                "n_relevant",
                "precision",
                "precision_worlds",
                "per_world",
                "precision_new_world",
            )
        },
        "check_on_unseen_worlds": check,
        "reaches_target": None if p is None else p >= 0.9,
        "within_slack_of_target": None if p is None else p >= 0.9 - 0.05,
        "within_stated_interval": None
        if check is None
        else check["worlds_inside_new_world_interval"][0] == check["worlds_inside_new_world_interval"][1],
    }
    key = None
    if args.rule != "point":
        figures = {"level": args.level, "seeds": tune_seeds, "rule": args.rule, **figures}
        figures["held_out"]["chosen"] = to_json(h.chosen)
        figures["point_rule"] = _point_rule(root, job, tune_seeds, check_seeds, args, ex)
        figures["alignments_read_back"] = args.reuse is not None
        figures["best_lowest_world_wilson"] = _best_lowest_world_wilson(job)
        key = f"{args.level}-{args.rule}"
        kept = json.loads(OUT.read_text(encoding="utf-8")) if OUT.is_file() else {}
        figures = {**kept, "rule_tunes": {**kept.get("rule_tunes", {}), key: figures}}
    elif args.level:
        figures = {"level": args.level, "seeds": tune_seeds, **figures}
        kept = json.loads(OUT.read_text(encoding="utf-8")) if OUT.is_file() else {}
        figures = {**kept, "level_tunes": {**kept.get("level_tunes", {}), args.level: figures}}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    tmp = OUT.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    tmp.replace(OUT)
    shown = figures["rule_tunes"][key] if key else figures["level_tunes"][args.level] if args.level else figures
    print(json.dumps(shown, indent=2, sort_keys=True))
    if not keep:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
