"""The paper-scale page's generated block (``docs/paper_scale.md``), rendered from committed files only.

Sources: the paper-scale reference runs ``results/reference/kimera_*/`` (``timings.json``,
``map_stats.json``, ``metrics.json``; written by ``roman-sim reproduce --scenario kimera_...``)
and ``benchmarks/out/scale.json`` (``python benchmarks/bench_scale.py ...``: the per-km probes,
gated against all pairs, one worker against two). ``python benchmarks/readme_scale.py``
rewrites the block between the ``paper-scale`` markers of ``docs/paper_scale.md``; a test
checks that the page holds exactly what ``render`` gives, so a figure that stops following
from the files fails CI.

The cost model is ``T(N) = km * m / min(N, robots) + pairs * a / N`` on N workers, with
``m`` the mapping seconds per km of trajectory and ``a`` the alignment seconds per pair of
all methods together, both measured on the largest paper-scale run. Candidate pairs grow
linearly with the kilometres when the area grows with them (the same pairs per km).
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
PAGE = Path("docs") / "paper_scale.md"
BEGIN, END = "<!-- paper-scale:begin -->", "<!-- paper-scale:end -->"
SCENARIOS = ("kimera_tunnel", "kimera_hybrid", "kimera_outdoor")
STAGES = ("world", "maps", "submaps", "evaluation", "posegraph", "ate", "report")


def _json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def _runs(root: Path) -> dict[str, dict[str, Any]]:
    """Per committed paper-scale reference run: its size and stage wall times."""
    out = {}
    for name in SCENARIOS:
        d = root / "results" / "reference" / name
        if not (d / "timings.json").is_file():
            continue
        t = _json(d / "timings.json")["stages"]
        ms = _json(d / "map_stats.json")
        m = _json(d / "metrics.json")
        ev = t.get("evaluation") or {}
        pairs = ev.get("pairs") or {}
        out[name] = {
            "robots": ms["robots"],
            "km": ms["trajectory_km"],
            "submaps": ms["submaps"],
            "pairs": m["n_pairs"],
            "candidates": m["n_candidates"],
            "skipped": m["n_skipped"],
            "cap_m": m["config"].get("max_pair_dist_m"),
            "stages": {s: (t.get(s) or {}).get("seconds") for s in STAGES},
            "workers": pairs.get("workers"),
            "executor": pairs.get("executor"),
            "align_mean_s": {k: v["mean"] for k, v in (ev.get("alignment") or {}).items()},
        }
    return out


def _f(v: float | None, digits: int = 1) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def _duration(s: float) -> str:
    if s >= 3600:
        return f"{s / 3600:.1f} h"
    if s >= 60:
        return f"{s / 60:.0f} min"
    return f"{s:.0f} s"


def _runs_table(runs: dict[str, dict[str, Any]]) -> list[str]:
    lines = [
        "| run | robots | km | submaps | pairs aligned (of candidates; cap) | maps | evaluation | "
        "other stages | total | workers |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in runs.items():
        st = r["stages"]
        other = sum(v for k, v in st.items() if k not in ("maps", "evaluation") and v is not None)
        total = sum(v for v in st.values() if v is not None)
        lines.append(
            f"| `{name}` | {r['robots']} | {_f(r['km'])} | {r['submaps']} | {r['pairs']} "
            f"(of {r['candidates']}; {_f(r['cap_m'], 0)} m) | {_duration(st['maps'] or 0.0)} | "
            f"{_duration(st['evaluation'] or 0.0)} | {_duration(other)} | {_duration(total)} | "
            f"{r['workers']} ({r['executor']}) |"
        )
    return lines


def _cost_model(runs: dict[str, dict[str, Any]], scale: dict[str, Any]) -> list[str]:
    big_name = max(runs, key=lambda n: runs[n]["km"])
    big = runs[big_name]
    m = big["stages"]["maps"] / big["km"]
    a = sum(big["align_mean_s"].values())
    methods = ", ".join(f"{k} {1000 * v:.1f} s" for k, v in sorted(big["align_mean_s"].items()))
    pairs_per_km = big["pairs"] / big["km"]
    lines = [
        f"Measured on `{big_name}` ({big['robots']} robots, {_f(big['km'])} km, {big['workers']} workers): "
        f"mapping m = {m:.0f} s per km of trajectory (render + segment + track, wall), alignment "
        f"a = {1000 * a:.1f} s per 1000 pairs of all methods together ({methods}), "
        f"{pairs_per_km:.0f} candidate pairs per km.",
        "",
    ]
    probes = [(n.removeprefix("probe_"), v) for n, v in sorted(scale.items()) if n.startswith("probe_")]
    if probes:
        lines += [
            "Mapping seconds per km on each paper-scale world (every robot stopped after "
            f"{probes[0][1]['length_m']:g} m, `bench_scale.py probe`): "
            + ", ".join(f"`{n}` {v['seconds_per_km']['maps']:.0f} s" for n, v in probes)
            + " (denser worlds put more objects in view).",
            "",
        ]
    lines += ["| experiment | km | pairs | 1 worker | 10 workers | 100 workers |", "|---|---|---|---|---|---|"]
    for factor in (1, 10, 100):
        km, pairs = big["km"] * factor, big["pairs"] * factor
        robots = big["robots"] * factor
        cells = [_duration(km * m / min(n, robots) + pairs * a / n) for n in (1, 10, 100)]
        lines.append(f"| {factor}x `{big_name}` ({robots} robots) | {km:.0f} | {pairs} | " + " | ".join(cells) + " |")
    return lines


def _gating(scale: dict[str, Any]) -> list[str]:
    out = []
    for key, g in sorted(scale.items()):
        if not key.startswith("pairs_") or "gated" not in g or "cross_robot" not in g["gated"]:
            continue
        name = key.removeprefix("pairs_")
        out += [
            f"On `{name}` ({g['workers']} workers, `gating.top_k` {g['top_k']}), cross-robot max recall "
            "(hits/relevant) per heading bin:",
            "",
            "| pairs | aligned | alignment wall time | method | 0-60 deg | 60-120 deg | 120-180 deg | all |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for tag in ("all_pairs", "gated"):
            r = g[tag]
            for method, cells in sorted(r["cross_robot"].items()):
                bins = [cells.get(b, "n/a") for b in ("0-60", "60-120", "120-180", "all")]
                out.append(
                    f"| {tag.replace('_', ' ')} | {r['aligned']} of {r['candidates']} | "
                    f"{_f(r['alignment_wall_s'], 0)} s | {method} | " + " | ".join(bins) + " |"
                )
        out.append("")
    return out


def _workers(scale: dict[str, Any]) -> list[str]:
    rows = []
    for key in ("demo_workers", "dask_smoke", "dask_demo"):
        v = scale.get(key)
        if not v:
            continue
        speed, target = v.get("speedup_2_over_1"), str(v.get("target", ""))
        found = re.findall(r"[\d.]+", target)
        number = float(found[-1]) if found else None
        if number is not None and "ratio" in target:  # a time ratio target: its speed-up is the inverse
            number = 1.0 / number
        verdict = "" if number is None else (" met" if speed >= number else " missed")
        rows.append(f"`{key}` {speed:.2f}x (target {_f(number, 2)}x{verdict})")
    if not rows:
        return []
    return [
        "Two workers against one, interleaved medians (`bench_scale.py demo` / `dask`): "
        + "; ".join(rows)
        + ". Serial work (the world's generation, the pose graphs, each stage's share in the main process) "
        "bounds the speed-up of a small run; on a machine shared with other login sessions the kernel shares the "
        "cores between sessions, so the speed-up holds only on free cores.",
        "",
    ]


def render(root: Path = ROOT) -> str:
    """The block between the paper-scale markers (markers included)."""
    runs = _runs(root)
    scale_path = root / "benchmarks" / "out" / "scale.json"
    scale = _json(scale_path) if scale_path.is_file() else {}
    lines = [BEGIN]
    if not runs:
        lines += [
            "No paper-scale reference run is committed yet (`roman-sim reproduce --scenario kimera_tunnel "
            "--scenario kimera_hybrid --scenario kimera_outdoor`)."
        ]
    else:
        lines += [
            "Paper-scale reference runs (seed 0; wall times on a shared 2-core machine, upper bounds):",
            "",
            *_runs_table(runs),
            "",
            "### Cost model",
            "",
            "Run time on N workers: `T(N) = km x m / min(N, robots) + pairs x a / N`.",
            "",
            *_cost_model(runs, scale),
            "",
            *_gating(scale),
            *_workers(scale),
        ]
    while lines[-1] == "":
        lines.pop()
    return "\n".join(lines + [END])


def update(root: Path = ROOT) -> None:
    """Rewrite the paper-scale block of ``root / PAGE`` from the files under ``root``."""
    page = root / PAGE
    text = page.read_text(encoding="utf-8")
    start, end = text.index(BEGIN), text.index(END) + len(END)
    page.write_text(text[:start] + render(root) + text[end:], encoding="utf-8")


if __name__ == "__main__":
    update(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT)
    print(render())
