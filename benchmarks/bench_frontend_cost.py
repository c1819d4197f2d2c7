"""What the front end's error model costs the demo: whole-run CPU with and without it.

Runs ``roman-sim run demo`` fresh in a subprocess with the default front end ("on") and with
the fastsam error model's under-segmentation, view-dependent splits, per-frame splits and
partial masks turned off and the descriptor confusion at level 0 ("off"), alternating the two
``--repeats`` times so that both see the same machine load. The runs are serial (one process),
so their user + system time (``RUSAGE_CHILDREN``) is all of the demo's CPU: a pool's workers
are forked by a forkserver the command does not wait for, and their time would be lost.
Writes ``benchmarks/out/frontend_cost.json`` with each run's CPU and wall seconds and the
ratio of the medians (on / off).

``--against PATH`` measures instead what a change of the code costs the demo: the default
demo of this checkout alternates with that of the checkout at PATH (e.g. the code before a
change unpacked with ``git archive``; its package first on ``PYTHONPATH``), both serial, and
the ratio of the medians (this / that) goes under ``against`` with the other checkout's note;
the file's other figures are kept.
Run: ``python benchmarks/bench_frontend_cost.py [--repeats N] [--against PATH --against-note TEXT]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

OUT = Path(__file__).resolve().parent / "out" / "frontend_cost.json"
OFF = [
    "frontend.segmenter.params.undersegment_prob=0",
    "frontend.segmenter.params.view_split_frac=0",
    "frontend.segmenter.params.oversegment_prob=0",
    "frontend.segmenter.params.partial_frac=0",
    "frontend.semantics.confusion.level=0",
]


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


ROOT = Path(__file__).resolve().parents[1]


def run_demo(overrides: list[str], tree: Path = ROOT) -> dict[str, float]:
    """CPU and wall seconds of one fresh demo run with ``overrides``, of the checkout at ``tree``."""
    with tempfile.TemporaryDirectory() as tmp:
        run_dir = str(Path(tmp) / "run")
        cmd = [sys.executable, "-m", "roman_sim.cli", "run", "demo", "--executor", "serial", "--out", run_dir]
        for o in overrides:
            cmd += ["--set", o]
        cpu0, t0 = _children_cpu(), time.perf_counter()
        env = {**os.environ, "MUJOCO_GL": "egl", "PYTHONPATH": str(tree), "ROMAN_SIM_CACHE": "off"}
        subprocess.run(cmd, check=True, capture_output=True, env=env, cwd=tree)
        return {"cpu_s": round(_children_cpu() - cpu0, 2), "wall_s": round(time.perf_counter() - t0, 2)}


Runs = dict[str, list[dict[str, float]]]


def alternate(
    first: Callable[[], dict[str, float]], second: Callable[[], dict[str, float]], names: tuple[str, str], repeats: int
) -> tuple[Runs, dict[str, float]]:
    """``repeats`` runs of each, alternating so both see the same load; the runs and their median CPU per name."""
    runs: Runs = {names[0]: [], names[1]: []}
    for _ in range(repeats):
        runs[names[0]].append(first())
        runs[names[1]].append(second())
    return runs, {k: statistics.median(r["cpu_s"] for r in v) for k, v in runs.items()}


def save(update: dict[str, Any]) -> None:
    """Merge ``update`` into the benchmark's file (its other figures kept), written atomically."""
    out = json.loads(OUT.read_text(encoding="utf-8")) if OUT.is_file() else {}
    out.update(update)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    tmp = OUT.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(out, indent=2) + "\n", encoding="utf-8")
    tmp.replace(OUT)
    print(json.dumps(update, indent=2))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--against", type=Path, default=None, help="alternate with the demo of the checkout at this path")
    ap.add_argument("--against-note", default="another checkout", help="what that checkout is")
    args = ap.parse_args()
    if args.against is not None:
        tree = args.against.resolve()
        runs, med = alternate(lambda: run_demo([]), lambda: run_demo([], tree), ("this", "other"), args.repeats)
        save(
            {
                "against": {
                    "other": args.against_note,
                    "runs": runs,
                    "median_cpu_s": med,
                    "cpu_ratio_this_over_other": round(med["this"] / med["other"], 3),
                    "load_average_after": [round(x, 2) for x in os.getloadavg()],
                    "note": "alternating serial runs of the default demo on one machine; CPU of the run's process",
                }
            }
        )
        return
    runs, med = alternate(lambda: run_demo([]), lambda: run_demo(OFF), ("on", "off"), args.repeats)
    save(
        {
            "scenario": "demo",
            "off_overrides": OFF,
            "runs": runs,
            "median_cpu_s": med,
            "cpu_ratio_on_over_off": round(med["on"] / med["off"], 3),
            "note": "alternating serial runs on one machine; CPU of the run's process",
        }
    )


if __name__ == "__main__":
    main()
