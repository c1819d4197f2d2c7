"""Reference results: run the paper's experiments and put them next to the paper's figures.

``reproduce`` runs each scenario (cached in a work folder), copies the small outputs
(``metrics.json``, ``ate.json``, ``report.md``, plots) to ``out_dir/<scenario>/`` and writes
``out_dir/summary.md`` and ``summary.json`` with the comparison table.
"""

from __future__ import annotations

import logging
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from roman_sim.core.atomic import write_json, write_text
from roman_sim.evaluation.report import fmt

log = logging.getLogger(__name__)

PAPER_SCENARIOS = [
    "same_direction", "partial_opposite", "opposite_direction", "heading_sweep",
    "multi_robot_tunnel", "multi_robot_hybrid", "multi_robot_outdoor",
]

#: The paper's figures (Kimera-Multi outdoor and the off-road Jackal experiment).
PAPER = {
    "max_recall_same_direction": 0.67,
    "max_recall_opposite_direction": 0.26,
    "ransac1m_over_roman_runtime": 4.5,
    "kb_per_submap_max": 250.0,
    "mb_per_km_max": 24.0,
    "ate_table": {"tunnel": (4.38, 4.20, 4.12), "hybrid": (5.83, 5.12, 4.77), "outdoor": (9.38, 8.77, 7.77)},
}

#: Paper-sized multi-robot scenarios (6-8 robots, about 1 km each; tens of minutes each), run on request:
#: ``roman-sim reproduce --scenario kimera_tunnel --scenario kimera_hybrid --scenario kimera_outdoor``.
PAPER_SCALE_SCENARIOS = ["kimera_tunnel", "kimera_hybrid", "kimera_outdoor"]

SMALL_FILES = ("metrics.json", "ate.json", "report.md", "config.yaml", "posegraph.json", "map_stats.json",
               "manifest.json", "timings.json")

#: The sweep run with the paper's scenarios: recall against the ambiguity knob.
AMBIGUITY_SWEEP = "sweeps/ambiguity_sweep.yaml"


def reproduce(
    out_dir: str | Path,
    scenarios: list[str] | None = None,
    work_dir: str | Path = "results/work",
    on_start: Callable[[str], None] | None = None,
    from_stage: str | None = None,
    executor: Any = None,
) -> Path:
    """Run ``scenarios`` (default: the paper's), collect small results, write the summary.

    ``executor`` (an ``ExecutorConfig``) spreads each run's robots and pairs over workers.
    """
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    out, work = Path(out_dir), Path(work_dir)
    runs: dict[str, Any] = {}
    for name in scenarios or PAPER_SCENARIOS:
        if on_start:
            on_start(name)
        res = Experiment(load_scenario(name), work / name, from_stage=from_stage, executor=executor).run()
        _collect(res.run_dir, out / name)
        runs[name] = {**res.metrics_summary(), "robots_connected": connected(res.run_dir, len(res.scenario.robots))}
    table = comparison(runs)
    sweep_rows: list[dict[str, Any]] = []
    if scenarios is None:
        if on_start:
            on_start("ambiguity_sweep")
        sweep_rows = ambiguity_sweep(out / "ambiguity_sweep", work / "ambiguity_sweep")
    write_json(out / "summary.json", {"runs": runs, "comparison": table, "ambiguity_sweep": sweep_rows,
                                      "paper": PAPER})
    write_text(out / "summary.md", summary_markdown(table) + sweep_markdown(sweep_rows))
    return out / "summary.md"


def ambiguity_sweep(dest: Path, work: Path) -> list[dict[str, Any]]:
    """Run (or resume) the ambiguity sweep; copy its table; rows of max recall per knob and method."""
    import csv

    from roman_sim.pipeline.scenario import SCENARIO_DIR
    from roman_sim.pipeline.sweep import load_sweep, run_sweep

    cfg, scenario = load_sweep(SCENARIO_DIR / AMBIGUITY_SWEEP)
    cfg.executor.kind = "serial"
    table = run_sweep(cfg, scenario, work)
    dest.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(table, dest / "sweep.csv")
    with table.open() as fh:
        return [{"ambiguity": r["world.overrides.ambiguity"], "method": r["method"],
                 "max_recall": float(r["max_recall"]) if r.get("max_recall") else None}
                for r in csv.DictReader(fh) if r.get("status") == "ok"]


def sweep_markdown(rows: list[dict[str, Any]]) -> str:
    """Max recall per ambiguity knob (rows) and method (columns)."""
    if not rows:
        return ""
    methods = sorted({r["method"] for r in rows})
    knobs = list(dict.fromkeys(r["ambiguity"] for r in rows))
    cell = {(r["ambiguity"], r["method"]): r["max_recall"] for r in rows}
    lines = ["", "## Max recall against the ambiguity knob (ambiguity sweep, opposite directions)", "",
             "| ambiguity | " + " | ".join(methods) + " |", "|---" * (len(methods) + 1) + "|"]
    lines += [f"| {k} | " + " | ".join(_fmt(cell.get((k, m))) for m in methods) + " |" for k in knobs]
    return "\n".join(lines) + "\n"


def connected(run_dir: Path, n_robots: int) -> dict[str, int]:
    """Per pose-graph variant: how many robots ended up in the first robot's frame."""
    import json

    try:
        graphs = json.loads((run_dir / "posegraph.json").read_text(encoding="utf-8"))
        return {k: n_robots - len(v.get("unconnected") or []) for k, v in graphs.items()}
    except (OSError, ValueError, AttributeError):
        return {}


def _collect(run_dir: Path, dest: Path) -> None:
    dest.mkdir(parents=True, exist_ok=True)
    for name in SMALL_FILES:
        if (run_dir / name).is_file():
            shutil.copyfile(run_dir / name, dest / name)
    if (run_dir / "plots").is_dir():
        shutil.copytree(run_dir / "plots", dest / "plots", dirs_exist_ok=True)


def _get(runs: dict[str, Any], scenario: str, *keys: str) -> Any:
    node: Any = runs.get(scenario)
    for k in keys:
        if not isinstance(node, dict):
            return None
        node = node.get(k)
    return node


def comparison(runs: dict[str, Any]) -> list[dict[str, Any]]:
    """Rows ``figure, paper, simulation, note`` for the README and summary.md."""
    rows = []
    for case, scen in (("same_direction", "same_direction"), ("opposite_direction", "opposite_direction")):
        rows.append({"figure": f"ROMAN max recall, {case.replace('_', ' ')}",
                     "paper": PAPER[f"max_recall_{case}"],
                     "simulation": _get(runs, scen, "methods", "roman", "max_recall")})
        rows.append({"figure": f"CLIPPER max recall, {case.replace('_', ' ')}", "paper": None,
                     "simulation": _get(runs, scen, "methods", "clipper", "max_recall")})
        rows.append({"figure": f"RANSAC-1M max recall, {case.replace('_', ' ')}", "paper": None,
                     "simulation": _get(runs, scen, "methods", "ransac1m", "max_recall")})
    ratios = []
    for scen in ("same_direction", "partial_opposite", "opposite_direction"):
        r1m = _get(runs, scen, "methods", "ransac1m", "runtime_median_s")
        ro = _get(runs, scen, "methods", "roman", "runtime_median_s")
        if r1m and ro:
            ratios.append(r1m / ro)
    rows.append({"figure": "RANSAC-1M / ROMAN runtime per pair", "paper": PAPER["ransac1m_over_roman_runtime"],
                 "simulation": max(ratios) if ratios else None})
    kb = [v for v in (_get(runs, s, "map", "kb_per_submap_max") for s in runs) if v is not None]
    mb = [v for v in (_get(runs, s, "map", "mb_per_km") for s in runs) if v is not None]
    rows.append({"figure": "largest submap packet (KB)", "paper": f"< {PAPER['kb_per_submap_max']:g}",
                 "simulation": max(kb) if kb else None})
    rows.append({"figure": "map size (MB per km)", "paper": f"< {PAPER['mb_per_km_max']:g}",
                 "simulation": max(mb) if mb else None})
    for variant, paper in PAPER["ate_table"].items():
        scen = f"multi_robot_{variant}"
        sim = tuple(_get(runs, scen, "ate_rmse_m", k) for k in ("odometry", "roman", "oracle"))
        rows.append({"figure": f"ATE RMSE {variant} (m): paper visual / ROMAN / combined; "
                               "simulation odometry / ROMAN / oracle", "paper": paper, "simulation": sim})
        big = f"kimera_{variant}"
        if big in runs:
            sim = tuple(_get(runs, big, "ate_rmse_m", k) for k in ("odometry", "roman", "oracle"))
            linked, total = _get(runs, big, "robots_connected", "roman"), _get(runs, big, "map", "robots")
            rows.append({"figure": f"ATE RMSE {variant}, paper scale ({big}; robots connected by ROMAN: "
                                   f"{linked}/{total})", "paper": paper, "simulation": sim})
    return rows


def _fmt(v: Any) -> str:
    if isinstance(v, (tuple, list)):
        return " / ".join(_fmt(x) for x in v)
    return fmt(v, 2)


def summary_markdown(rows: list[dict[str, Any]]) -> str:
    """The comparison table as markdown."""
    lines = ["# Reference results next to the paper", "", "| figure | paper | simulation |", "|---|---|---|"]
    lines += [f"| {r['figure']} | {_fmt(r['paper'])} | {_fmt(r['simulation'])} |" for r in rows]
    return "\n".join(lines) + "\n"
