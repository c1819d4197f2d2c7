"""A run's evaluation files: tidy ``pairs.csv`` and ``metrics.json``, written atomically.

``pairs.csv`` holds one row per (pair, method) with the pair's truth and the method's
outcome; empty cells are undefined values (NaN / no reason). The true relative pose is
stored as x, y, z, yaw, which is exact because submap frames are gravity-aligned. Floats
are written with ``repr`` (exact round trip), so ``metrics.json`` can be recomputed from
this file alone (``roman_sim.report.recompute``). A path ending in ``.gz`` is read as
gzip (the reference results keep their tables compressed).
``metrics.json`` is the ``EvaluationMetrics`` record (``roman_sim.core.records``). Neither
holds wall-clock runtimes (two runs of one seed give the same bytes); those are kept in
``timings.json``. Reading either file back raises ``StorageError`` when it is missing or
corrupt (for ``metrics.json``, a ``RecordError`` naming the file and the field).
"""

from __future__ import annotations

import csv
import gzip
import io
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import StorageError
from roman_sim.core.geometry import pose_4dof, yaw_of
from roman_sim.core.records import read_record, write_record
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.evaluation.types import METRICS_SCHEMA, EvaluationMetrics

log = logging.getLogger(__name__)

PAIRS_CSV = "pairs.csv"
METRICS_JSON = "metrics.json"

PAIRS_FIELDS = [
    "a",
    "b",
    "robot_a",
    "robot_b",
    "index_a",
    "index_b",
    "kind",
    "center_dist_m",
    "heading_diff_deg",
    "overlap",
    "shared_objects",
    "true_corr",
    "ambiguity",
    "relevant",
    "true_x_m",
    "true_y_m",
    "true_z_m",
    "true_yaw_rad",
    "method",
    "n_assoc",
    "assoc_correct",
    "assoc_recovered",
    "rot_err_deg",
    "trans_err_m",
    "correct",
    "reason",
]


def _fmt(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (float, np.floating)):
        return "" if math.isnan(v) else repr(float(v))
    if isinstance(v, np.integer):
        return str(int(v))
    return str(v)


def _row(s: PairScore) -> dict[str, str]:
    t = s.truth
    T = t.T_a_b_true
    vals: dict[str, Any] = {
        "a": t.a,
        "b": t.b,
        "robot_a": t.robot_a,
        "robot_b": t.robot_b,
        "index_a": t.index_a,
        "index_b": t.index_b,
        "kind": t.kind,
        "center_dist_m": t.center_dist_m,
        "heading_diff_deg": t.heading_diff_deg,
        "overlap": t.overlap,
        "shared_objects": t.shared_objects,
        "true_corr": t.true_correspondences,
        "ambiguity": t.ambiguity,
        "relevant": t.relevant,
        "true_x_m": float(T[0, 3]),
        "true_y_m": float(T[1, 3]),
        "true_z_m": float(T[2, 3]),
        "true_yaw_rad": yaw_of(T),
        "method": s.method,
        "n_assoc": s.n_assoc,
        "assoc_correct": s.assoc_correct,
        "assoc_recovered": s.assoc_recovered,
        "rot_err_deg": s.rot_err_deg,
        "trans_err_m": s.trans_err_m,
        "correct": s.correct,
        "reason": s.reason,
    }
    return {k: _fmt(vals[k]) for k in PAIRS_FIELDS}


def pairs_csv_text(scores: list[PairScore]) -> str:
    """The CSV text of ``scores`` (header + one row per score)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=PAIRS_FIELDS, lineterminator="\n")
    w.writeheader()
    for s in scores:
        w.writerow(_row(s))
    return buf.getvalue()


def write_pairs_csv(path: str | Path, scores: list[PairScore]) -> Path:
    """Atomically write ``pairs.csv``."""
    path = Path(path)
    write_text(path, pairs_csv_text(scores))
    log.info("wrote %d rows to %s", len(scores), path)
    return path


def _float(raw: str) -> float:
    return float("nan") if raw == "" else float(raw)


def _bool(raw: str) -> bool:
    if raw not in ("true", "false"):
        raise ValueError(f"expected true/false, got {raw!r}")
    return raw == "true"


def _parse(r: dict[str, str]) -> PairScore:
    T = pose_4dof(float(r["true_x_m"]), float(r["true_y_m"]), float(r["true_z_m"]), float(r["true_yaw_rad"]))
    if r["kind"] not in ("inter", "intra"):
        raise ValueError(f"kind must be inter or intra, got {r['kind']!r}")
    truth = PairTruth(
        a=r["a"],
        b=r["b"],
        robot_a=r["robot_a"],
        robot_b=r["robot_b"],
        index_a=int(r["index_a"]),
        index_b=int(r["index_b"]),
        T_a_b_true=T,
        center_dist_m=float(r["center_dist_m"]),
        heading_diff_deg=float(r["heading_diff_deg"]),
        overlap=_float(r["overlap"]),
        ambiguity=_float(r["ambiguity"]),
        relevant=_bool(r["relevant"]),
        kind=r["kind"],  # type: ignore[arg-type]
        shared_objects=int(r["shared_objects"]),
        true_correspondences=int(r["true_corr"]),
    )
    return PairScore(
        truth,
        r["method"],
        int(r["n_assoc"]),
        _float(r["rot_err_deg"]),
        _float(r["trans_err_m"]),
        _bool(r["correct"]),
        float("nan"),
        r["reason"] or None,
        int(r["assoc_correct"]),
        int(r["assoc_recovered"]),
    )


def read_pairs_csv(path: str | Path) -> list[PairScore]:
    """Read ``pairs.csv`` back into scores.

    Raises:
        StorageError: missing file, wrong header, or a malformed row (with its line).
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
        text = (gzip.decompress(raw) if path.suffix == ".gz" else raw).decode("utf-8")
    except (OSError, UnicodeDecodeError, EOFError, gzip.BadGzipFile) as err:
        raise StorageError(f"{path}: cannot read pairs table ({err.__class__.__name__})") from None
    reader = csv.DictReader(io.StringIO(text))
    missing = [f for f in PAIRS_FIELDS if f not in (reader.fieldnames or [])]
    if missing:
        raise StorageError(f"{path}: not a pairs table, missing columns: {', '.join(missing)}")
    out = []
    for row in reader:
        if None in row or any(v is None for v in row.values()):
            raise StorageError(f"{path}: line {reader.line_num}: wrong number of cells")
        try:
            out.append(_parse(row))
        except (ValueError, KeyError) as err:
            raise StorageError(f"{path}: line {reader.line_num}: {err}") from None
    return out


def write_metrics_json(path: str | Path, metrics: EvaluationMetrics) -> Path:
    """Atomically write ``metrics.json``: on one line without spaces, the one format of runs and committed results."""
    return write_record(path, metrics, METRICS_SCHEMA, tight=True)


def read_metrics_json(path: str | Path) -> EvaluationMetrics:
    """Read ``metrics.json``.

    Raises:
        RecordError: missing, not JSON, wrong schema, or a field missing or of another type (the
            message names the file and the field).
    """
    return read_record(path, EvaluationMetrics, METRICS_SCHEMA)


def write_evaluation(out_dir: str | Path, scores: list[PairScore], metrics: EvaluationMetrics) -> dict[str, Path]:
    """Write ``pairs.csv`` and ``metrics.json`` into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    return {
        "pairs": write_pairs_csv(out / PAIRS_CSV, scores),
        "metrics": write_metrics_json(out / METRICS_JSON, metrics),
    }


def read_evaluation(out_dir: str | Path) -> tuple[list[PairScore], EvaluationMetrics]:
    """Read a run folder's ``pairs.csv`` and ``metrics.json`` (StorageError if either is bad)."""
    out = Path(out_dir)
    return read_pairs_csv(out / PAIRS_CSV), read_metrics_json(out / METRICS_JSON)
