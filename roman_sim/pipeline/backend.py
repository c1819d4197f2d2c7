"""Stages evaluation -> pose graph -> report."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from roman_sim.align import build_aligner
from roman_sim.align.base import AlignResult
from roman_sim.core.atomic import write_json
from roman_sim.core.errors import RomanSimError, StorageError
from roman_sim.evaluation.evaluate import evaluate, save_evaluation
from roman_sim.evaluation.results import read_evaluation
from roman_sim.mapping.types import Submap

if TYPE_CHECKING:
    from roman_sim.pipeline.experiment import Experiment

log = logging.getLogger(__name__)

ALIGNMENTS_JSON = "alignments.json"


class Labelled:
    """Runs an aligner under the scenario's label (so two settings of one method can coexist)."""

    def __init__(self, inner: Any, name: str) -> None:
        self.inner = inner
        self.name = name

    def align(self, a: Submap, b: Submap) -> AlignResult:
        res = self.inner.align(a, b)
        res.method = self.name
        return res


class Counting:
    """Reports progress as pairs are aligned by the last aligner of the list."""

    def __init__(self, inner: Any, exp: "Experiment") -> None:
        self.inner, self.exp, self.name = inner, exp, inner.name

    def align(self, a: Submap, b: Submap) -> AlignResult:
        res = self.inner.align(a, b)
        self.exp.progress.advance("evaluation:pairs")
        return res


def all_submaps(exp: "Experiment") -> list[Submap]:
    return [s for subs in exp._state["submaps"].values() for s in subs]


def build_aligners(exp: "Experiment") -> list[Any]:
    """The scenario's aligners, labelled; the last one counts pairs for the progress bar."""
    out = [Labelled(build_aligner(e.method, e.params), e.name) for e in exp.sc.aligners]
    out[-1] = Counting(out[-1], exp)
    return out


def evaluation_files(exp: "Experiment") -> list[Path]:
    return [exp.dir / "pairs.csv", exp.dir / "metrics.json", exp.dir / ALIGNMENTS_JSON]


def evaluation_stage(exp: "Experiment") -> None:
    """Run every aligner on every pair, score, and write pairs.csv, metrics.json, plots."""
    from roman_sim.evaluation.pairs import enumerate_pairs

    submaps = all_submaps(exp)
    ec = exp.sc.evaluation
    pairs = enumerate_pairs(submaps, ec.intra_min_gap, ec.max_pair_dist_m, ec.relevant_dist_m)
    exp.progress.start("evaluation:pairs", len(pairs))
    ev = evaluate(submaps, build_aligners(exp), ec, ambiguity_fn=_ambiguity_fn(exp), pairs=pairs)
    exp.progress.end("evaluation:pairs")
    save_evaluation(exp.dir, ev, submaps, map_view=True)
    alignments = _alignments_record(ev.results)
    write_json(exp.dir / ALIGNMENTS_JSON, alignments)
    exp._state["evaluation"] = ev
    exp._state["alignments"] = alignments
    exp._state["metrics"] = ev.metrics
    exp._state["truths"] = {(t.a, t.b): t for t in ev.truths}
    exp.result.notes.extend(ev.notes)


def _ambiguity_fn(exp: "Experiment") -> Any:
    """Ground-truth place ambiguity at submap scale, when the world was generated in this run."""
    from roman_sim.evaluation.pairs import world_ambiguity_fn

    world = exp._state.get("world")
    return None if world is None else world_ambiguity_fn(world.truth, exp.sc.submaps.submap_radius)


def _alignments_record(results: dict[tuple[str, str, str], AlignResult]) -> list[dict[str, Any]]:
    rows = []
    for (a, b, method), r in sorted(results.items()):
        rows.append({"a": a, "b": b, "method": method, "n_associations": r.n_associations,
                     "T_a_b": None if r.T_a_b is None else np.round(r.T_a_b, 9).tolist()})
    return rows


def load_evaluation_stage(exp: "Experiment") -> None:
    import json

    scores, metrics = read_evaluation(exp.dir)
    path = exp.dir / ALIGNMENTS_JSON
    try:
        exp._state["alignments"] = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise StorageError(f"{path}: unreadable ({err}); re-run with --fresh") from None
    exp._state["metrics"] = metrics
    exp._state["truths"] = {(s.truth.a, s.truth.b): s.truth for s in scores}


def posegraph_files(exp: "Experiment") -> list[Path]:
    return [exp.dir / "ate.json"] if exp.sc.posegraph_method else []


def posegraph_stage(exp: "Experiment") -> None:
    """Pose graphs (odometry only / method / oracle closures) and their trajectory errors."""
    from roman_sim.pipeline.trajectories import solve_and_score

    if exp.sc.posegraph_method is None or "maps" not in exp._state:
        note = ("pose graph skipped: no posegraph_method" if exp.sc.posegraph_method is None
                else "pose graph skipped: no trajectories (run started from saved submaps)")
        exp.result.notes.append(note)
        exp._state["ate"] = {}
        return
    exp._state["ate"] = solve_and_score(exp)
    write_json(exp.dir / "ate.json", exp._state["ate"])


def load_posegraph_stage(exp: "Experiment") -> None:
    import json

    path = exp.dir / "ate.json"
    try:
        exp._state["ate"] = json.loads(path.read_text()) if path.is_file() else {}
    except (OSError, ValueError) as err:
        raise StorageError(f"{path}: unreadable ({err}); re-run with --fresh") from None


def report_stage(exp: "Experiment") -> None:
    """Map statistics, metrics.json (with ATE and map size), report.md."""
    from roman_sim.evaluation.report import write_report
    from roman_sim.evaluation.results import write_metrics_json

    metrics = dict(exp._state.get("metrics", {}))
    stats = map_stats(exp)
    ate = exp._state.get("ate", {})
    metrics["ate"] = ate
    metrics["map"] = stats
    metrics["scenario"] = exp.sc.name
    metrics["seed"] = exp.sc.seed
    write_metrics_json(exp.dir / "metrics.json", metrics)
    notes = list(dict.fromkeys(exp.result.notes + exp._state.get("pg_notes", [])))
    write_report(exp.dir, exp.sc.name, metrics, ate_table=_ate_table(ate), map_stats=stats, notes=notes)
    exp.result.metrics, exp.result.ate, exp.result.map_stats = metrics, ate, stats
    exp.result.notes = notes


def _ate_table(ate: dict[str, Any]) -> dict[str, Any] | None:
    if not ate:
        return None
    return {variant: {al: v.get("all") for al, v in per.items()} for variant, per in ate.items()}


def map_stats(exp: "Experiment") -> dict[str, Any]:
    """Segments, submaps, packet size per submap and MB per km of trajectory."""
    from roman_sim.mapping.io import packet_bytes

    submaps = all_submaps(exp)
    maps = exp._state.get("maps", {})
    length_m = sum(m.trajectory_length_m for m in maps.values())
    sizes = [packet_bytes(s) for s in submaps]
    stats: dict[str, Any] = {
        "robots": len(exp._state["submaps"]),
        "segments": sum(len(m) for m in maps.values()) if maps else None,
        "submaps": len(submaps),
        "segments_per_submap": float(np.mean([len(s) for s in submaps])) if submaps else None,
        "kb_per_submap": float(np.mean(sizes)) / 1000.0 if sizes else None,
        "kb_per_submap_max": float(np.max(sizes)) / 1000.0 if sizes else None,
        "trajectory_km": length_m / 1000.0 if maps else None,
        "mb_per_km": (sum(sizes) / 1e6) / (length_m / 1000.0) if maps and length_m > 0 else None,
    }
    return stats


def load_stage(exp: "Experiment", name: str) -> None:
    """Reload a cached stage's outputs into the experiment's state."""
    from roman_sim.pipeline.frontend import load_frontend_stage

    try:
        if name in ("maps", "submaps"):
            load_frontend_stage(exp, name)
        elif name == "evaluation":
            load_evaluation_stage(exp)
        elif name == "posegraph":
            load_posegraph_stage(exp)
    except RomanSimError as err:
        raise StorageError(f"cached stage {name!r} in {exp.dir} is unusable: {err} (re-run with --fresh)") from None
