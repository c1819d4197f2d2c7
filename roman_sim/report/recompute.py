"""A finished run's figures recomputed from its raw files, and the comparison with the stored ones.

- ``metrics.json`` from ``pairs.csv`` and the evaluation settings in ``config.yaml``
  (``recompute_metrics``): every pair's relevance and correctness are re-derived from its true
  distance, shared objects and errors (``rederive_scores``), then every figure is recomputed
  (``metrics.compute_metrics``, the acceptance operating points at ``posegraph.lc_association_thresh``).
  The number of pairs a distance cap skipped is not in ``pairs.csv``; it is taken from
  ``metrics.json``. A file written before the operating points existed is compared without
  them (and the check says so).
- ``ate.json`` from ``trajectories/*.tum`` (``recompute_ate``): for each variant, the
  trajectories of the robots it placed (and the truth) are read and the table is recomputed
  (``atetable.ate_table``).

``check_run_files`` runs both and returns a ``Verification``: what was checked, what differed.
Numbers match when they agree within ``rel_tol`` (the recomputation is the same arithmetic,
so a run verified on the machine that wrote it matches exactly; SVDs may differ in the last
bits between machines). ``report --verify`` adds a check independent of this code
(``roman_sim.studies.verify``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from roman_sim.core.config import read_yaml, validate_model
from roman_sim.core.errors import RomanSimError
from roman_sim.core.records import RecordError, read_json, to_json_object, to_json_record
from roman_sim.core.tum import read_tum
from roman_sim.evaluation.atetable import AteTable, TrajectoryVariant, ate_table, read_ate
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import PairScore, compute_metrics, is_correct
from roman_sim.evaluation.operating_points import strip_absent_points
from roman_sim.evaluation.records import RunTimings, read_map_stats, read_timings
from roman_sim.evaluation.results import METRICS_JSON, PAIRS_CSV, read_metrics_json, read_pairs_csv
from roman_sim.evaluation.run_summary import RunSummary, summarize_run
from roman_sim.evaluation.types import METRICS_SCHEMA, EvaluationMetrics
from roman_sim.evaluation.variants import TRUTH

ATE_JSON = "ate.json"
REL_TOL = 1e-9


@dataclass
class Verification:
    """What was checked, what differed, and what could not be compared (``notes``)."""

    checked: list[str] = field(default_factory=list)
    differences: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether every recomputed figure matched."""
        return not self.differences


def compare(expected: Any, got: Any, where: str = "", rel_tol: float = REL_TOL, abs_tol: float = 1e-12) -> list[str]:
    """Paths at which two JSON-like values differ (numbers within tolerance count as equal)."""
    if isinstance(expected, dict) and isinstance(got, dict):
        out = [f"{where}/{k}: missing in the recomputation" for k in expected if k not in got]
        out += [f"{where}/{k}: not in the file" for k in got if k not in expected]
        for k in expected:
            if k in got:
                out += compare(expected[k], got[k], f"{where}/{k}", rel_tol, abs_tol)
        return out
    if isinstance(expected, list) and isinstance(got, list):
        if len(expected) != len(got):
            return [f"{where}: {len(expected)} entries in the file, {len(got)} recomputed"]
        return [
            d for i, (a, b) in enumerate(zip(expected, got)) for d in compare(a, b, f"{where}[{i}]", rel_tol, abs_tol)
        ]
    numbers = (int, float)
    if isinstance(expected, numbers) and isinstance(got, numbers) and not isinstance(expected, bool):
        if math.isclose(float(expected), float(got), rel_tol=rel_tol, abs_tol=abs_tol):
            return []
    elif expected == got:
        return []
    return [f"{where}: file has {expected!r}, recomputed {got!r}"]


def eval_settings(run_dir: Path) -> tuple[EvalConfig, int]:
    """The evaluation settings and the pose graph's acceptance threshold of a run's ``config.yaml``."""
    from roman_sim.posegraph import PoseGraphConfig

    data = read_yaml(run_dir / "config.yaml")
    data = data if isinstance(data, dict) else {}
    cfg = validate_model(EvalConfig, data.get("evaluation") or {}, source=f"{run_dir / 'config.yaml'}: evaluation")
    pg = validate_model(PoseGraphConfig, data.get("posegraph") or {}, source=f"{run_dir / 'config.yaml'}: posegraph")
    return cfg, pg.lc_association_thresh


def rederive_scores(scores: list[PairScore], cfg: EvalConfig) -> tuple[list[PairScore], list[str]]:
    """Scores with relevance and correctness recomputed from the raw columns; rows that disagree."""
    out, diffs = [], []
    for i, s in enumerate(scores):
        rel = cfg.is_relevant(s.truth.center_dist_m, s.truth.shared_objects)
        ok = is_correct(s.rot_err_deg, s.trans_err_m, cfg)
        if rel != s.truth.relevant:
            diffs.append(
                f"pairs.csv row {i + 1} ({s.truth.a}|{s.truth.b}): relevant={s.truth.relevant}, recomputed {rel}"
            )
        if ok != s.correct:
            diffs.append(
                f"pairs.csv row {i + 1} ({s.truth.a}|{s.truth.b}, {s.method}): correct={s.correct}, recomputed {ok}"
            )
        out.append(replace(s, truth=replace(s.truth, relevant=rel), correct=ok))
    return out, diffs


def recompute_metrics(
    run_dir: Path, pairs_file: str = PAIRS_CSV, as_stored: bool = True
) -> tuple[EvaluationMetrics, list[str]]:
    """``metrics.json`` as recomputed from ``pairs_file`` and ``config.yaml``, and row-level differences.

    ``as_stored``: leave out the figures the stored ``metrics.json`` predates (to compare with
    it); False keeps every figure the current code derives from the pairs (to summarise a run).
    """
    cfg, acceptance_k = eval_settings(run_dir)
    scores, diffs = rederive_scores(read_pairs_csv(run_dir / pairs_file), cfg)
    stored = read_metrics_json(run_dir / METRICS_JSON)
    metrics = compute_metrics(scores, cfg, stored.n_skipped, acceptance_k, _n_segments(run_dir))
    metrics.frontend = stored.frontend  # the front end's grades come from the maps, not from the pairs table
    if stored.robot_pairs is None:  # written before the per-robot-pair counts were recorded
        metrics.robot_pairs = None
    if as_stored and stored.revisits is None:  # written before the revisit figures were recorded
        metrics.revisits = None
    return metrics, diffs


def _n_segments(run_dir: Path) -> int | None:
    """0 when ``map_stats.json`` says the submaps hold no segment at all, else None (unknown to the pairs table)."""
    try:
        stats, _ = read_map_stats(run_dir / "map_stats.json")
    except RecordError:
        return None
    return 0 if stats.segments_per_submap == 0 else None


def recompute_ate(run_dir: Path, suffix: str = "") -> AteTable:
    """``ate.json`` as recomputed from the TUM files of the robots each variant placed.

    ``suffix`` is appended to the TUM file names (``.gz`` for compressed reference results).
    """
    stored, _ = read_ate(run_dir / ATE_JSON)
    truth = {r: read_tum(_tum(run_dir, TRUTH, r, suffix)) for r in stored.robots}
    variants = {v: TrajectoryVariant(row.description, row.fit, row.source) for v, row in stored.variants.items()}
    trajectories = {
        row.source: {r: read_tum(_tum(run_dir, row.source, r, suffix)) for r in row.connected}
        for row in stored.variants.values()
    }
    alignments = tuple(next(iter(stored.variants.values())).rmse) if stored.variants else ()
    return ate_table(truth, variants, trajectories, alignments)


def _tum(run_dir: Path, variant: str, robot: str, suffix: str) -> Path:
    return run_dir / "trajectories" / f"{robot}.{variant}.tum{suffix}"


def stored_summary(run_dir: Path) -> RunSummary:
    """The run's compact summary as its stored files give it (metrics, ATE, map statistics, timings)."""
    metrics = read_metrics_json(run_dir / METRICS_JSON)
    ate = None
    if (run_dir / ATE_JSON).is_file():
        ate, _ = read_ate(run_dir / ATE_JSON)
    stats = None
    if (run_dir / "map_stats.json").is_file():
        stats, _ = read_map_stats(run_dir / "map_stats.json")
    timings = read_timings(run_dir / "timings.json") if (run_dir / "timings.json").is_file() else RunTimings()
    runtimes = {m: timings.median_s(m) for m in metrics.methods}
    return summarize_run(metrics, ate, stats, runtimes)


def check_run_files(
    run_dir: str | Path, rel_tol: float = REL_TOL, pairs_file: str = PAIRS_CSV, tum_suffix: str = ""
) -> Verification:
    """Recompute ``metrics.json`` (and ``ate.json`` when present) and list every difference."""
    d = Path(run_dir)
    out = Verification()
    metrics, rows = recompute_metrics(d, pairs_file)
    out.checked.append(f"metrics.json from {pairs_file}")
    stored = read_json(d / METRICS_JSON)  # as written (checked by recompute_metrics): which figures it predates
    again = to_json_object(to_json_record(metrics, METRICS_SCHEMA))
    if strip_absent_points(stored, again):
        out.notes.append(
            "metrics.json predates the operating points: it and the independent scorer's figures were "
            "compared without them"
        )
    out.differences += rows + compare(stored, again, "metrics.json", rel_tol)
    if (d / ATE_JSON).is_file():
        try:
            table = recompute_ate(d, tum_suffix)
        except RomanSimError as err:
            out.differences.append(f"ate.json: cannot recompute ({err})")
        else:
            out.checked.append("ate.json from trajectories/*.tum")
            stored_ate = to_json_object(read_ate(d / ATE_JSON)[0].record())
            out.differences += compare(stored_ate, to_json_object(table.record()), "ate.json", max(rel_tol, 1e-7), 1e-9)
    return out
