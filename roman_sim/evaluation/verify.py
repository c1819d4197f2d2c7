"""Independent check of a finished run: recompute its figures from the raw files and compare.

- ``metrics.json`` from ``pairs.csv`` and the evaluation settings in ``config.yaml``: every
  pair's relevance and correctness are re-derived from its true distance, shared objects and
  errors, then every figure is recomputed (``metrics.summary``). The number of pairs a
  distance cap skipped is not in ``pairs.csv``; it is taken from ``metrics.json``.
- ``ate.json`` from ``trajectories/*.tum``: for each variant, the trajectories of the robots
  it placed (and the truth) are read and the table is recomputed (``atetable.ate_table``).

``verify_run`` returns the list of differences (empty: everything matches). Numbers match
when they agree within ``rel_tol`` (the recomputation is the same arithmetic, so a run
verified on the machine that wrote it matches exactly; SVDs may differ in the last bits
between machines).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from roman_sim.core.config import read_yaml, validate_model
from roman_sim.core.errors import RomanSimError, StorageError
from roman_sim.core.tum import read_tum
from roman_sim.evaluation.atetable import AteTable, VariantEstimate, ate_table
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import PairScore, is_correct, summary
from roman_sim.evaluation.results import METRICS_JSON, PAIRS_CSV, read_metrics_json, read_pairs_csv
from roman_sim.evaluation.types import EvaluationMetrics

ATE_JSON = "ate.json"
REL_TOL = 1e-9


@dataclass
class Verification:
    """What was checked and what differed."""

    checked: list[str] = field(default_factory=list)
    differences: list[str] = field(default_factory=list)

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


def _eval_config(run_dir: Path) -> EvalConfig:
    data = read_yaml(run_dir / "config.yaml")
    section = data.get("evaluation", {}) if isinstance(data, dict) else {}
    return validate_model(EvalConfig, section or {}, source=f"{run_dir / 'config.yaml'}: evaluation")


def rederive(scores: list[PairScore], cfg: EvalConfig) -> tuple[list[PairScore], list[str]]:
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


def recompute_metrics(run_dir: Path, pairs_file: str = PAIRS_CSV) -> tuple[EvaluationMetrics, list[str]]:
    """``metrics.json`` as recomputed from ``pairs_file`` and ``config.yaml``, and row-level differences."""
    cfg = _eval_config(run_dir)
    scores, diffs = rederive(read_pairs_csv(run_dir / pairs_file), cfg)
    stored = read_metrics_json(run_dir / METRICS_JSON)
    metrics = summary(scores, cfg, stored.n_skipped)
    metrics.frontend = stored.frontend  # the front end's grades come from the maps, not from the pairs table
    if stored.robot_pairs is None:  # written before the per-robot-pair counts were recorded
        metrics.robot_pairs = None
    return metrics, diffs


def recompute_ate(run_dir: Path, suffix: str = "") -> AteTable:
    """``ate.json`` as recomputed from the TUM files of the robots each variant placed.

    ``suffix`` is appended to the TUM file names (``.gz`` for compressed reference results).
    """
    try:
        path = run_dir / ATE_JSON
        stored = AteTable.from_json(json.loads(path.read_text(encoding="utf-8")), str(path))
    except (OSError, ValueError) as err:
        raise StorageError(f"{run_dir / ATE_JSON}: unreadable ({type(err).__name__})") from None
    truth = {r: read_tum(_tum(run_dir, "truth", r, suffix)) for r in stored.robots}
    estimates = {
        v: VariantEstimate(
            {r: read_tum(_tum(run_dir, row.source, r, suffix)) for r in row.connected},
            row.fit,  # type: ignore[arg-type]
            row.description,
            row.source,
        )
        for v, row in stored.variants.items()
    }
    return ate_table(truth, estimates, tuple(next(iter(stored.variants.values())).rmse) if stored.variants else ())


def _tum(run_dir: Path, variant: str, robot: str, suffix: str) -> Path:
    return run_dir / "trajectories" / f"{robot}.{variant}.tum{suffix}"


def verify_run(
    run_dir: str | Path, rel_tol: float = REL_TOL, pairs_file: str = PAIRS_CSV, tum_suffix: str = ""
) -> Verification:
    """Recompute ``metrics.json`` (and ``ate.json`` when present) and list every difference."""
    d = Path(run_dir)
    out = Verification()
    metrics, rows = recompute_metrics(d, pairs_file)
    out.checked.append(f"metrics.json from {pairs_file}")
    stored = json.loads((d / METRICS_JSON).read_text(encoding="utf-8"))
    out.differences += rows + compare(stored, metrics.to_json(), "metrics.json", rel_tol)
    if (d / ATE_JSON).is_file():
        try:
            table = recompute_ate(d, tum_suffix)
        except RomanSimError as err:
            out.differences.append(f"ate.json: cannot recompute ({err})")
        else:
            out.checked.append("ate.json from trajectories/*.tum")
            stored_ate = json.loads((d / ATE_JSON).read_text(encoding="utf-8"))
            stored_ate.pop("notes", None)
            out.differences += compare(stored_ate, table.to_json(), "ate.json", max(rel_tol, 1e-7), 1e-9)
    return out
