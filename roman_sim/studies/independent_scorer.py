"""An independent scorer of finished runs: the summary figures recomputed from the raw files alone.

The claims of the reference results must not be checked with the code that produced them.
This module therefore imports nothing from ``roman_sim.evaluation``, ``roman_sim.report`` or
``roman_sim.pipeline``: it reads the raw files with the standard library and numpy, and
applies the evaluation's definitions, written out again here:

- a pair is *relevant* when its true submap centres are at most ``relevant_dist_m`` apart
  (or, with ``relevance: shared_objects``, when it shares at least ``min_shared_objects``
  true objects);
- an estimate ``T_a_b`` is *correct* when the rotation angle of ``inv(T_true) @ T_est`` is at
  most ``rot_tol_deg`` and ``|t_est - t_true|`` at most ``trans_tol_m``; the true pose of a
  pair is its gravity-aligned relative pose (translation ``true_x/y/z_m``, yaw
  ``true_yaw_rad``), re-read from ``pairs.csv``; the estimate from ``alignments.json``;
- at threshold k a pair is *positive* when the method accepted at least k associations;
  TP(k) = relevant, positive and correct; FP(k) = positive and not correct;
  max hits = max over k of TP(k); hits at precision 1 = the largest TP(k) among the k with
  TP(k) > 0 and FP(k) = 0 (0 when there is none); recall = hits / relevant, with a Wilson
  score interval;
- operating points (per pair set and heading bin), with precision = TP / (TP + FP) compared
  in exact fractions: ``max_recall`` at the highest k of the sweep that keeps max hits (with
  no hit at all, the lowest k); ``precision_90`` / ``precision_100`` at the smallest k whose
  precision is at least 9/10 / exactly 1 (a k without a positive has no precision), else
  not reached (k None, hits and false positives 0); ``acceptance`` at k = the run's
  ``posegraph.lc_association_thresh`` as given (absent when the config has none). Each
  carries hits, relevant pairs, false positives, recall and precision (None when their
  denominator is 0) and the Wilson intervals of both;
- heading bins are ``[lo, hi)``, the last one closed;
- the ATE is the RMSE of position errors after the least-squares rigid alignment (Umeyama
  without scale) of the estimate onto the truth, over poses matched by timestamp; "joint"
  variants align all their robots at once, "per_robot" ones each robot on its own and pool
  the squared errors; ``common`` is over the robots every variant placed, ``all`` over every
  robot for the variants that placed them all;
- runtimes are the medians of the per-pair runtimes (``runtimes.csv``);
- a submap packet is the compressed archive of its public fields (pose, time, index,
  segment ids, float32 centres, volumes, shape and extents, float16 descriptors), rebuilt
  from the saved packets (``packets/<robot>.npz``) and compressed again here.

``score_run`` gives, for one run folder, the figures of its compact summary that the
reference claims use, in the same JSON shape; ``agreement`` compares them with a committed
summary (``points`` included). Association precision/recall, F1 and AUC are not recomputed (no claim uses them).
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import math
import statistics
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import StorageError
from roman_sim.core.yamlio import read_yaml

F64 = NDArray[np.float64]
#: A JSON-ready value (the summary's shape).
JSONValue = object
#: Fields of ``pairs.csv`` the scorer reads.
PAIR_FIELDS = (
    "a",
    "b",
    "kind",
    "center_dist_m",
    "heading_diff_deg",
    "overlap",
    "shared_objects",
    "true_x_m",
    "true_y_m",
    "true_z_m",
    "true_yaw_rad",
    "method",
    "n_assoc",
)
TIME_DECIMALS = 6
#: Operating points and the precision each must reach (None: no target), in table order.
POINTS: dict[str, Fraction | None] = {
    "max_recall": None,
    "precision_90": Fraction(9, 10),
    "precision_100": Fraction(1),
    "acceptance": None,
}


@dataclass(frozen=True)
class Settings:
    """The evaluation settings of a run, read from its ``config.yaml``."""

    relevance: str
    relevant_dist_m: float
    min_shared_objects: int
    rot_tol_deg: float
    trans_tol_m: float
    k_min: int
    k_max: int
    heading_bins_deg: tuple[float, ...]
    min_relevant: int
    interval_level: float
    acceptance_k: int | None = None


@dataclass(frozen=True)
class Pair:
    """One method's result on one pair: what the scorer needs, nothing derived."""

    a: str
    b: str
    kind: str
    center_dist_m: float
    heading_diff_deg: float
    overlap: float
    shared_objects: int
    T_true: F64
    method: str
    n_assoc: int


def _open_text(path: Path) -> io.TextIOBase:
    if not path.is_file():
        raise StorageError(f"{path}: missing")
    if path.suffix == ".gz":
        return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8")
    return io.TextIOWrapper(path.open("rb"), encoding="utf-8")


def _raw(run_dir: Path, name: str) -> Path:
    """``name`` in the run folder, or its gzip copy (reference results keep raw files compressed)."""
    plain = run_dir / name
    return plain if plain.is_file() else run_dir / f"{name}.gz"


def read_settings(run_dir: Path) -> Settings:
    """The ``evaluation`` section of the run's resolved ``config.yaml`` and the pose graph's
    acceptance threshold (``posegraph.lc_association_thresh``; None when the file has none)."""
    data = read_yaml(run_dir / "config.yaml")
    ev = data.get("evaluation") if isinstance(data, dict) else None
    if not isinstance(ev, dict):
        raise StorageError(f"{run_dir / 'config.yaml'}: no evaluation section")
    pg = data.get("posegraph") if isinstance(data, dict) else None
    acc = pg.get("lc_association_thresh") if isinstance(pg, dict) else None
    try:
        return Settings(
            str(ev["relevance"]),
            float(ev["relevant_dist_m"]),
            int(ev["min_shared_objects"]),
            float(ev["rot_tol_deg"]),
            float(ev["trans_tol_m"]),
            int(ev["k_min"]),
            int(ev["k_max"]),
            tuple(float(x) for x in ev["heading_bins_deg"]),
            int(ev["min_relevant"]),
            float(ev["interval_level"]),
            None if acc is None else int(acc),
        )
    except (KeyError, TypeError, ValueError) as err:
        raise StorageError(f"{run_dir / 'config.yaml'}: evaluation section lacks {err}") from None


def pose_4dof(x: float, y: float, z: float, yaw: float) -> F64:
    """The 4x4 pose with translation (x, y, z) and a rotation of ``yaw`` about z."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]])


def read_pairs(path: Path) -> list[Pair]:
    """Every row of a ``pairs.csv`` (plain or gzip)."""
    with _open_text(path) as fh:
        reader = csv.DictReader(fh)
        missing = [f for f in PAIR_FIELDS if f not in (reader.fieldnames or [])]
        if missing:
            raise StorageError(f"{path}: columns missing: {', '.join(missing)}")
        return [
            Pair(
                r["a"],
                r["b"],
                r["kind"],
                float(r["center_dist_m"]),
                float(r["heading_diff_deg"]),
                float(r["overlap"]) if r["overlap"] not in ("", "nan") else math.nan,
                int(r["shared_objects"]),
                pose_4dof(float(r["true_x_m"]), float(r["true_y_m"]), float(r["true_z_m"]), float(r["true_yaw_rad"])),
                r["method"],
                int(r["n_assoc"]),
            )
            for r in reader
        ]


def read_estimates(path: Path) -> dict[tuple[str, str, str], F64 | None]:
    """``(a, b, method) -> T_a_b`` (None where the method gave no estimate) from ``alignments.json``."""
    with _open_text(path) as fh:
        data = json.load(fh)
    out: dict[tuple[str, str, str], F64 | None] = {}
    for rec in data["alignments"]:
        T = rec["T_a_b"]
        out[(rec["a"], rec["b"], rec["method"])] = None if T is None else np.asarray(T, dtype=np.float64)
    return out


def pose_errors(T_est: F64, T_true: F64) -> tuple[float, float]:
    """(rotation error deg, translation error m) of an estimate against the truth."""
    R = T_true[:3, :3].T @ T_est[:3, :3]
    cos = min(1.0, max(-1.0, (float(np.trace(R)) - 1.0) / 2.0))
    return math.degrees(math.acos(cos)), float(np.linalg.norm(T_est[:3, 3] - T_true[:3, 3]))


def wilson_interval(k: int, n: int, level: float) -> list[float] | None:
    """Wilson score interval of k successes in n trials (no continuity correction); None for n = 0."""
    if n == 0:
        return None
    z = statistics.NormalDist().inv_cdf(0.5 + level / 2.0)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return [max(0.0, centre - half), min(1.0, centre + half)]


@dataclass(frozen=True)
class Judged:
    """One scored row: relevance, correctness, association count and heading."""

    relevant: bool
    correct: bool
    n_assoc: int
    heading_diff_deg: float


def judge(pairs: Sequence[Pair], estimates: Mapping[tuple[str, str, str], F64 | None], cfg: Settings) -> list[Judged]:
    """Relevance and correctness of every row, from the truth columns and the saved estimates."""
    out = []
    for p in pairs:
        if cfg.relevance == "shared_objects":
            relevant = p.shared_objects >= cfg.min_shared_objects
        else:
            relevant = p.center_dist_m <= cfg.relevant_dist_m
        T = estimates.get((p.a, p.b, p.method))
        correct = False
        if T is not None:
            rot, trans = pose_errors(T, p.T_true)
            correct = rot <= cfg.rot_tol_deg and trans <= cfg.trans_tol_m
        out.append(Judged(relevant, correct, p.n_assoc, p.heading_diff_deg))
    return out


def recall_record(rows: Sequence[Judged], cfg: Settings) -> dict[str, JSONValue]:
    """max recall, its hits and relevant count, interval, small-set flag, hits at precision 1 and
    the operating points."""
    n_rel = sum(r.relevant for r in rows)
    best, best_p1 = _hits(rows, cfg)
    return {
        "max_recall": best / n_rel if n_rel else None,
        "max_hits": best,
        "n_relevant": n_rel,
        "recall_ci": wilson_interval(best, n_rel, cfg.interval_level),
        "few": n_rel < cfg.min_relevant,
        "points": operating_points(rows, cfg),
        "recall_at_precision_1": best_p1 / n_rel if n_rel else None,
        "hits_at_precision_1": best_p1,
    }


def _counts(rows: Sequence[Judged], k: int) -> tuple[int, int]:
    """(TP(k), FP(k)): positives (at least k associations) relevant and correct / not correct."""
    pos = [r for r in rows if r.n_assoc >= k]
    return sum(r.relevant and r.correct for r in pos), sum(not r.correct for r in pos)


def _hits(rows: Sequence[Judged], cfg: Settings) -> tuple[int, int]:
    """(max over k of TP(k), max TP(k) over the k where TP(k) > 0 and FP(k) = 0)."""
    best, best_p1 = 0, 0
    for k in range(cfg.k_min, cfg.k_max + 1):
        tp, fp = _counts(rows, k)
        best = max(best, tp)
        if fp == 0 and tp > 0:
            best_p1 = max(best_p1, tp)
    return best, best_p1


def point_record(
    k: int | None, tp: int, fp: int, n_relevant: int, level: float, reached: bool = True
) -> dict[str, JSONValue]:
    """One operating point: threshold, counts, recall and precision with their Wilson intervals.

    A point not reached has k None and no hit or false positive (recall 0, precision None).
    """
    if not reached:
        tp, fp = 0, 0
    pos = tp + fp
    return {
        "k": k,
        "reached": reached,
        "hits": tp,
        "n_relevant": n_relevant,
        "false_positives": fp,
        "recall": tp / n_relevant if n_relevant else None,
        "recall_ci": wilson_interval(tp, n_relevant, level),
        "precision": tp / pos if pos else None,
        "precision_ci": wilson_interval(tp, pos, level),
    }


def operating_points(rows: Sequence[Judged], cfg: Settings) -> dict[str, JSONValue]:
    """The operating points of ``rows`` over k = ``k_min..k_max`` (and at ``acceptance_k`` when set)."""
    n_rel = sum(r.relevant for r in rows)
    level = cfg.interval_level
    sweep = [(k, *_counts(rows, k)) for k in range(cfg.k_min, cfg.k_max + 1)]
    out: dict[str, JSONValue] = {}
    if not sweep:
        out = {name: point_record(None, 0, 0, n_rel, level, reached=False) for name in POINTS if name != "acceptance"}
    else:
        best = max(tp for _, tp, _ in sweep)
        k, tp, fp = [s for s in sweep if s[1] == best][-1] if best else sweep[0]
        out["max_recall"] = point_record(k, tp, fp, n_rel, level)
        for name, target in POINTS.items():
            if target is None:
                continue
            ok = [s for s in sweep if s[1] + s[2] > 0 and Fraction(s[1], s[1] + s[2]) >= target]
            out[name] = point_record(*ok[0], n_rel, level) if ok else point_record(None, 0, 0, n_rel, level, False)
    if cfg.acceptance_k is not None:
        out["acceptance"] = point_record(cfg.acceptance_k, *_counts(rows, cfg.acceptance_k), n_rel, level)
    return out


def _max_hits(rows: Sequence[Judged], cfg: Settings) -> int:
    return _hits(rows, cfg)[0]


def heading_bin(value: float, edges: Sequence[float]) -> int:
    """Bin of a heading difference: ``[lo, hi)``, the last bin closed; -1 outside or NaN."""
    if math.isnan(value) or value < edges[0] or value > edges[-1]:
        return -1
    for i in range(len(edges) - 1):
        if value < edges[i + 1] or (i == len(edges) - 2 and value == edges[-1]):
            return i
    return -1


def _label(lo: float, hi: float) -> str:
    return f"{lo:g}-{hi:g}"


def method_figures(rows: Sequence[Judged], kinds: Sequence[str], cfg: Settings) -> dict[str, JSONValue]:
    """Per pair set (``inter``, ``intra``): the recall record, pair count and coarse heading bins."""
    out: dict[str, JSONValue] = {}
    for kind in ("inter", "intra"):
        mine = [r for r, k in zip(rows, kinds) if k == kind]
        rec = recall_record(mine, cfg)
        rec["n_pairs"] = len(mine)
        edges = cfg.heading_bins_deg
        bins: dict[str, JSONValue] = {}
        for i, (lo, hi) in enumerate(zip(edges, edges[1:])):
            in_bin = [r for r in mine if heading_bin(r.heading_diff_deg, edges) == i]
            full = recall_record(in_bin, cfg)
            keys = ("max_recall", "max_hits", "n_relevant", "recall_ci", "few", "points")
            bins[_label(lo, hi)] = {k: full[k] for k in keys}
        rec["bins"] = bins
        out[kind] = rec
    return out


def read_runtimes(path: Path) -> dict[str, list[float]]:
    """method -> per-pair alignment runtimes (s) from ``runtimes.csv`` (plain or gzip)."""
    out: dict[str, list[float]] = {}
    with _open_text(path) as fh:
        for r in csv.DictReader(fh):
            v = float(r["runtime_s"])
            if math.isfinite(v):
                out.setdefault(r["method"], []).append(v)
    return out


def _timings(run_dir: Path) -> dict[str, list[float]]:
    """method -> per-pair runtimes from a run folder's ``timings.json`` (empty when it has none)."""
    try:
        data = json.loads((run_dir / "timings.json").read_text(encoding="utf-8"))
        alignment = data["stages"]["evaluation"]["alignment"]
        return {
            m: [float(v) for v in rec["per_pair_s"] if math.isfinite(float(v))]
            for m, rec in alignment.items()
            if rec.get("per_pair_s")
        }
    except (OSError, ValueError, KeyError, TypeError):
        return {}


# -- trajectories ----------------------------------------------------------------------------
def read_tum_positions(path: Path) -> dict[float, F64]:
    """Timestamp (rounded to 1 us) -> position, from a TUM file (plain or gzip)."""
    out: dict[float, F64] = {}
    with _open_text(path) as fh:
        for line in fh:
            parts = line.split()
            if not parts or parts[0].startswith("#"):
                continue
            out[round(float(parts[0]), TIME_DECIMALS)] = np.array([float(v) for v in parts[1:4]])
    return out


def umeyama_residuals(est: F64, ref: F64) -> F64:
    """Position errors after the rigid transform (no scale) that best maps ``est`` onto ``ref``."""
    ce, cr = est.mean(axis=0), ref.mean(axis=0)
    H = (est - ce).T @ (ref - cr)
    U, _, Vt = np.linalg.svd(H)
    S = np.diag([1.0, 1.0, 1.0 if np.linalg.det(Vt.T @ U.T) >= 0 else -1.0])
    R = Vt.T @ S @ U.T
    return np.linalg.norm(ref - (est @ R.T + (cr - R @ ce)), axis=1)


def _matched(est: dict[float, F64], ref: dict[float, F64]) -> tuple[F64, F64]:
    times = sorted(set(est) & set(ref))
    return np.array([est[t] for t in times]).reshape(-1, 3), np.array([ref[t] for t in times]).reshape(-1, 3)


def ate_rmse(
    est: Mapping[str, dict[float, F64]], ref: Mapping[str, dict[float, F64]], robots: Sequence[str], fit: str
) -> float | None:
    """SE(3) ATE RMSE over ``robots`` (joint alignment, or per robot with pooled squared errors)."""
    if not robots:
        return None
    pairs = [_matched(est[r], ref[r]) for r in robots]
    if any(len(e) < 3 for e, _ in pairs):
        return None
    if fit == "per_robot":
        sq = np.concatenate([umeyama_residuals(e, r) ** 2 for e, r in pairs])
    else:
        sq = umeyama_residuals(np.vstack([e for e, _ in pairs]), np.vstack([r for _, r in pairs])) ** 2
    return float(math.sqrt(float(np.mean(sq))))


def ate_figures(run_dir: Path) -> tuple[dict[str, JSONValue], dict[str, JSONValue]]:
    """(``ate`` per variant: connected, common, all; ``ate_robots``) recomputed from the TUM files.

    Which robots each variant placed is read from ``posegraph.json`` (robots not
    ``unconnected``; odometry places every robot); the variant names, their sources and fits
    from ``ate.json``'s rows, whose figures are not read.
    """
    with _open_text(run_dir / "ate.json") as fh:
        table = json.load(fh)
    with _open_text(_raw(run_dir, "posegraph.json")) as fh:
        graphs = json.load(fh)
    robots = list(table["robots"])
    placed = {}
    for row in table["variants"]:
        unconnected = set((graphs.get(row["source"]) or {}).get("unconnected", []))
        placed[row["name"]] = [r for r in robots if r not in unconnected]
    common = [r for r in robots if all(r in p for p in placed.values())]
    traj_dir = run_dir / "trajectories"

    def tum(variant: str, robot: str) -> dict[float, F64]:
        return read_tum_positions(_raw(traj_dir, f"{robot}.{variant}.tum"))

    truth = {r: tum("truth", r) for r in robots}
    ate: dict[str, JSONValue] = {}
    for row in table["variants"]:
        est = {r: tum(row["source"], r) for r in placed[row["name"]]}
        every = len(placed[row["name"]]) == len(robots)
        ate[row["name"]] = {
            "connected": len(placed[row["name"]]),
            "common": ate_rmse(est, truth, common, row["fit"]),
            "all": ate_rmse(est, truth, robots, row["fit"]) if every else None,
        }
    return ate, {"robots": robots, "common": common}


# -- packets ---------------------------------------------------------------------------------
PACKET_FIELDS = ("T_odom_submap", "t", "index", "segment_ids", "centers", "volumes", "shape", "extents", "descriptors")


def packet_sizes(path: Path) -> list[int]:
    """Compressed bytes of each submap packet saved in one robot's ``packets/<robot>.npz``.

    The file holds, per submap k, the arrays ``s<k>_<field>`` of ``PACKET_FIELDS`` but the
    descriptors, which are stored once per segment (``descriptor_ids``, ``descriptor_table``);
    each packet is rebuilt (its descriptors looked up by its segment ids) and compressed
    again here, on its own.
    """
    with np.load(path, allow_pickle=False) as z:
        names = set(z.files)
        row = {int(sid): i for i, sid in enumerate(z["descriptor_ids"])}
        table = z["descriptor_table"]
        k, sizes = 0, []
        while f"s{k}_centers" in names:
            arrays = {f: z[f"s{k}_{f}"] for f in PACKET_FIELDS if f != "descriptors"}
            ids = arrays["segment_ids"]
            arrays["descriptors"] = table[[row[int(i)] for i in ids]] if len(ids) else table[:0]
            buf = io.BytesIO()
            np.savez_compressed(buf, **{f: arrays[f] for f in PACKET_FIELDS})
            sizes.append(len(buf.getvalue()))
            k += 1
    return sizes


def map_figures(run_dir: Path) -> dict[str, JSONValue] | None:
    """Largest and mean packet (KB) and MB per km, from the saved packets; None without them.

    The trajectory length is the run's (``map_stats.json``'s ``trajectory_km``: it is a fact of
    the robots' paths, not a figure derived by the scoring).
    """
    folder = run_dir / "packets"
    if not folder.is_dir():
        return None
    sizes = [s for p in sorted(folder.glob("*.npz")) for s in packet_sizes(p)]
    with _open_text(run_dir / "map_stats.json") as fh:
        km = json.load(fh).get("trajectory_km")
    if not sizes:
        return None
    return {
        "kb_per_submap": float(np.mean(sizes)) / 1000.0,
        "kb_per_submap_max": float(max(sizes)) / 1000.0,
        "mb_per_km": (sum(sizes) / 1e6) / km if km else None,
        "submaps": len(sizes),
    }


# -- a run -----------------------------------------------------------------------------------
def judged_rows(run_dir: Path) -> tuple[Settings, list[Pair], list[Judged]]:
    """A run's settings, its pairs table and every row judged (relevance, correctness)."""
    cfg = read_settings(run_dir)
    pairs = read_pairs(_raw(run_dir, "pairs.csv"))
    return cfg, pairs, judge(pairs, read_estimates(_raw(run_dir, "alignments.json")), cfg)


def score_run(run_dir: str | Path) -> dict[str, JSONValue]:
    """The figures of a run's compact summary that the claims use, recomputed from its raw files."""
    d = Path(run_dir)
    cfg, pairs, judged = judged_rows(d)
    methods: dict[str, JSONValue] = {}
    runtimes = read_runtimes(_raw(d, "runtimes.csv")) if _raw(d, "runtimes.csv").is_file() else _timings(d)
    for m in sorted({p.method for p in pairs}):
        idx = [i for i, p in enumerate(pairs) if p.method == m]
        figures = method_figures([judged[i] for i in idx], [pairs[i].kind for i in idx], cfg)
        if runtimes:
            figures["runtime_median_s"] = statistics.median(runtimes[m]) if runtimes.get(m) else None
        methods[m] = figures
    out: dict[str, JSONValue] = {"methods": methods, "pairs": _pair_counts(pairs, judged)}
    revisits = _revisits(pairs, judged)
    if revisits is not None:
        out["revisits"] = revisits
    if (d / "ate.json").is_file() and (d / "trajectories").is_dir():
        out["ate"], out["ate_robots"] = ate_figures(d)
    packets = map_figures(d)
    if packets is not None:
        out["map"] = packets
    return out


def sweep_rows(folder: str | Path) -> list[dict[str, JSONValue]]:
    """Cross-robot rows of a one-knob sweep: per knob value and method, hits and relevant pairs pooled
    over the seeds, the pooled recall, its Wilson interval and the number of seeds.

    Reads ``sweep.json`` (its grid and runs) and scores each run folder under ``folder``.
    """
    d = Path(folder)
    with _open_text(d / "sweep.json") as fh:
        spec = json.load(fh)
    if len(spec["grid"]) != 1:
        raise StorageError(f"{d / 'sweep.json'}: a one-knob sweep expected, grid has {len(spec['grid'])} keys")
    key = spec["grid"][0]
    pooled: dict[tuple[float, str], list[int]] = {}
    level = 0.95
    for run in spec["runs"]:
        cfg, pairs, judged = judged_rows(d / run["run_id"])
        level = cfg.interval_level
        for m in sorted({p.method for p in pairs}):
            rows = [j for p, j in zip(pairs, judged) if p.method == m and p.kind == "inter"]
            hits = _max_hits(rows, cfg)
            acc = pooled.setdefault((float(run["params"][key]), m), [0, 0, 0])
            acc[0] += hits
            acc[1] += sum(r.relevant for r in rows)
            acc[2] += 1
    return [
        {
            "ambiguity": knob,
            "method": method,
            "recall": hits / rel if rel else None,
            "hits": hits,
            "relevant": rel,
            "ci": wilson_interval(hits, rel, level),
            "n_seeds": seeds,
        }
        for (knob, method), (hits, rel, seeds) in sorted(pooled.items())
    ]


def _pair_counts(pairs: Sequence[Pair], judged: Sequence[Judged]) -> dict[str, JSONValue]:
    seen: dict[tuple[str, str], tuple[str, bool]] = {}
    for p, j in zip(pairs, judged):
        seen[(p.a, p.b)] = (p.kind, j.relevant)
    return {
        k: {
            "n_pairs": sum(1 for kind, _ in seen.values() if k == "all" or kind == k),
            "n_relevant": sum(1 for kind, rel in seen.values() if (k == "all" or kind == k) and rel),
        }
        for k in ("inter", "intra", "all")
    }


def _revisits(pairs: Sequence[Pair], judged: Sequence[Judged]) -> dict[str, JSONValue] | None:
    """Median overlap and shared objects over the relevant cross-robot pairs (None without cross-robot pairs)."""
    seen: dict[tuple[str, str], tuple[float, int]] = {}
    inter = False
    for p, j in zip(pairs, judged):
        if p.kind == "inter":
            inter = True
            if j.relevant:
                seen[(p.a, p.b)] = (p.overlap, p.shared_objects)
    if not inter:
        return None
    overlaps = sorted(o for o, _ in seen.values() if not math.isnan(o))
    shared = sorted(float(n) for _, n in seen.values())
    return {
        "n_relevant": len(seen),
        "median_overlap": statistics.median(overlaps) if overlaps else None,
        "median_shared_objects": statistics.median(shared) if shared else None,
    }


def _walk(expected: JSONValue, got: JSONValue, where: str, rel_tol: float, map_rel_tol: float) -> Iterator[str]:
    if isinstance(got, dict):
        if not isinstance(expected, dict):
            yield f"{where}: summary has {expected!r}, the scorer a mapping"
            return
        for k, v in got.items():
            if k not in expected:
                yield f"{where}/{k}: not in the summary"
            else:
                yield from _walk(expected[k], v, f"{where}/{k}", rel_tol, map_rel_tol)
    elif isinstance(got, list):
        if not isinstance(expected, list) or len(expected) != len(got):
            yield f"{where}: summary has {expected!r}, the scorer {got!r}"
            return
        for i, (e, g) in enumerate(zip(expected, got)):
            yield from _walk(e, g, f"{where}[{i}]", rel_tol, map_rel_tol)
    elif isinstance(got, float) and isinstance(expected, (int, float)) and not isinstance(expected, bool):
        tol = map_rel_tol if where.startswith("/map/") else rel_tol
        if not math.isclose(got, float(expected), rel_tol=tol, abs_tol=1e-12):
            yield f"{where}: summary has {expected!r}, the scorer {got!r}"
    elif expected != got:
        yield f"{where}: summary has {expected!r}, the scorer {got!r}"


def agreement(summary_run: JSONValue, scored: JSONValue, rel_tol: float = 1e-6, map_rel_tol: float = 0.02) -> list[str]:
    """Every place where the scorer's figures differ from a committed run summary (empty: all agree).

    Only the scorer's keys are compared. Numbers agree within ``rel_tol`` (SVDs and sums may
    differ in their last bits between machines); packet sizes within ``map_rel_tol``, since
    another zlib may compress the same arrays to a few bytes more or less.
    """
    return list(_walk(summary_run, scored, "", rel_tol, map_rel_tol))


#: One judged cross-robot row of a benchmark cell: cell, robot pair, relevant, correct, associations, heading.
BenchRow = tuple[str, str, bool, bool, int, float]


def _benchmark_rows(folder: Path) -> tuple[dict[str, JSONValue], dict[str, list[BenchRow]]]:
    """``benchmark.json`` and, per (level, method) key ``level|method``, its cross-robot rows
    (cell, robot pair, relevant, correct, associations, heading), judged from the raw columns
    (errors ``rot_err_deg`` / ``trans_err_m`` against the cell's tolerances; empty: no estimate)."""
    rec = json.loads((folder / "benchmark.json").read_text(encoding="utf-8"))
    rows: dict[str, list[BenchRow]] = {}
    for c in rec["cells"]:
        if c["status"] != "ok":
            continue
        cell = folder / "cells" / c["id"]
        cfg = read_settings(cell)
        with _open_text(_raw(cell, "pairs.csv")) as fh:
            for r in csv.DictReader(fh):
                if r["kind"] != "inter":
                    continue
                if cfg.relevance == "shared_objects":
                    rel = int(r["shared_objects"]) >= cfg.min_shared_objects
                else:
                    rel = float(r["center_dist_m"]) <= cfg.relevant_dist_m
                rot, trans = (float(r[f] or "nan") for f in ("rot_err_deg", "trans_err_m"))
                ok = rot <= cfg.rot_tol_deg and trans <= cfg.trans_tol_m  # no estimate (NaN): not correct
                robots = "|".join(sorted((r["robot_a"], r["robot_b"])))
                row = (c["id"], robots, rel, ok, int(r["n_assoc"]), float(r["heading_diff_deg"]))
                rows.setdefault(f"{c['level']}|{r['method']}", []).append(row)
    return rec, rows


def _smallest_k(rows: Sequence[BenchRow], ks: range, target: Fraction) -> int | None:
    """The smallest k whose precision over ``rows`` (all headings) is at least ``target`` (None: none)."""
    for k in ks:
        tp = sum(1 for r in rows if r[4] >= k and r[2] and r[3])
        fp = sum(1 for r in rows if r[4] >= k and not r[3])
        if tp + fp > 0 and tp * target.denominator >= target.numerator * (tp + fp):
            return k
    return None


#: The benchmark's world bootstrap, as its documentation states the protocol: start with 20 000 draws, double
#: them (up to 640 000) while a decision is within 4 Monte-Carlo errors; the Monte-Carlo error of a bound is
#: the standard deviation of that bound over 20 equal batches of the draws, over the square root of 20.
BOOT_MIN, BOOT_MAX, BOOT_BATCHES, BOOT_MARGIN, BOOT_LEVEL = 20_000, 640_000, 20, 4.0, 0.95
#: Held-out hits below which a method is a floor in a bin; the effect the verdicts' power is for.
FLOOR_HITS, EFFECT = 10, 0.05


def _ratio_draws(rng: np.random.Generator, num: F64, den: F64, draws: int) -> F64:
    """``draws`` draws of sum(num) / sum(den) over worlds drawn with replacement (``rng.integers(0, n, (draws,
    n))``), the draws whose denominator sums to 0 left out."""
    picks = rng.integers(0, len(num), (draws, len(num)))
    top, bottom = num[picks].sum(axis=1), den[picks].sum(axis=1)
    keep = bottom > 0
    return top[keep] / bottom[keep]


def _percentiles(values: F64) -> tuple[float, float, float]:
    """The 2.5 and 97.5 % quantiles and the Monte-Carlo error of the two (the larger)."""
    q = [(1 - BOOT_LEVEL) / 2, 1 - (1 - BOOT_LEVEL) / 2]
    lo, hi = np.quantile(values, q)
    per = np.array([np.quantile(part, q) for part in np.array_split(values, BOOT_BATCHES)])
    return float(lo), float(hi), float(per.std(axis=0, ddof=1).max() / math.sqrt(BOOT_BATCHES))


def world_boot(
    num: Sequence[float] | F64,
    den: Sequence[float] | F64,
    decide_at: float | None = None,
    half_width: bool = False,
    seed: int = 0,
) -> dict[str, float] | None:
    """The world bootstrap of sum(num) / sum(den) (one entry per world): ``low``, ``high``, ``se``, ``draws``,
    ``err``. The draws double while a bound (or, with ``half_width``, the half-width) is within the margin of
    ``decide_at``; None with fewer than two worlds or no denominator at all."""
    n, d = np.asarray(num, dtype=np.float64), np.asarray(den, dtype=np.float64)
    if len(n) < 2 or not (d > 0).any():
        return None
    rng = np.random.default_rng(seed)
    values, draws = _ratio_draws(rng, n, d, BOOT_MIN), BOOT_MIN
    lo, hi, err = _percentiles(values)

    def close() -> bool:
        if decide_at is None or err <= 0:
            return False
        if half_width:
            return abs((hi - lo) / 2 - decide_at) <= BOOT_MARGIN * err
        return abs(lo - decide_at) <= BOOT_MARGIN * err or abs(hi - decide_at) <= BOOT_MARGIN * err

    while draws < BOOT_MAX and close():
        values = np.concatenate([values, _ratio_draws(rng, n, d, draws)])
        draws *= 2
        lo, hi, err = _percentiles(values)
    return {"low": lo, "high": hi, "se": float(values.std(ddof=1)), "draws": draws, "err": err}


def sign_flip_p_value(diffs: Sequence[int]) -> float:
    """Exact two-sided p-value of the sum of whole-number ``diffs`` under random signs, by counting every sum
    the ``2^W`` sign choices reach (a dictionary of sum -> ways, one world at a time)."""
    ways = {0: 1}
    for d in diffs:
        step: dict[int, int] = {}
        for total, n in ways.items():
            for signed in {d, -d}:
                step[total + signed] = step.get(total + signed, 0) + n * (2 if d == 0 else 1)
        ways = step
    observed = abs(sum(diffs))
    return sum(n for total, n in ways.items() if abs(total) >= observed) / 2 ** len(diffs)


def paired_verdict(hits_a: Sequence[int], hits_b: Sequence[int], relevant: Sequence[int]) -> dict:
    """Two methods' paired verdict over worlds: ``verdict`` (``a ahead``, ``b ahead``, ``no difference shown``,
    ``too few hits``), ``diff``, ``p_value`` (exact sign-flip, two-sided) and ``power`` (two-sided, normal,
    with the world-clustered standard error of the ratio, for ``EFFECT``) and ``detectable`` (the difference
    detected with power 0.8 at that standard error)."""
    from scipy.stats import norm

    d = [int(x) - int(y) for x, y in zip(hits_a, hits_b, strict=True)]
    n = [int(x) for x in relevant]
    total = sum(n)
    diff = sum(d) / total if total else 0.0
    w = len(d)
    se = math.sqrt(w / (w - 1) * sum((x - diff * m) ** 2 for x, m in zip(d, n, strict=True))) / total if total else 0
    z = norm.ppf(0.5 + BOOT_LEVEL / 2)
    power = 1.0 if se <= 0 else float(norm.cdf(EFFECT / se - z) + norm.cdf(-EFFECT / se - z))
    p = sign_flip_p_value(d)
    if sum(hits_a) < FLOOR_HITS and sum(hits_b) < FLOOR_HITS:
        verdict = "too few hits"
    elif p <= 1 - BOOT_LEVEL and diff != 0:
        verdict = "a ahead" if diff > 0 else "b ahead"
    else:
        verdict = "no difference shown"
    detect = float((z + norm.ppf(0.8)) * se)
    return {"verdict": verdict, "diff": diff, "p_value": p, "power": power, "detectable": detect}


def _level_methods(
    folder: Path, rows: Mapping[str, list[BenchRow]]
) -> Iterator[tuple[str, list[BenchRow], list[str], Settings]]:
    """Per ``level|method`` with two worlds or more: its rows, its worlds (sorted) and its first cell's settings."""
    for key, rs in rows.items():
        worlds = sorted({r[0] for r in rs})
        if len(worlds) >= 2:
            yield key, rs, worlds, read_settings(folder / "cells" / worlds[0])


def benchmark_held_out(folder: str | Path, target: Fraction = Fraction(9, 10)) -> dict[str, JSONValue]:
    """Held-out figures of a benchmark folder, per ``level|method``: the threshold chosen for each
    world (cell) on the level's other worlds (smallest k of the sweep whose pooled precision over all
    headings of their cross-robot pairs reaches ``target``), and per heading bin (and ``all``) the held-out
    [hits, false positives, relevant] with every world scored at its own held-out threshold
    (``bins``), the same per world (``worlds``: three lists over the sorted worlds), and the recall's
    Wilson interval and the world-bootstrap intervals of recall and precision (``intervals``:
    ``recall_wilson``, ``recall_worlds``, ``precision_worlds``; ``world_boot`` over the worlds, the recall's
    draws doubled while its half-width is near 0.1)."""
    folder = Path(folder)
    rec, rows = _benchmark_rows(folder)
    raw_edges = rec["heading_edges_deg"]
    if not isinstance(raw_edges, list):
        raise StorageError(f"{folder / 'benchmark.json'}: heading_edges_deg is not a list")
    edges = [float(e) for e in raw_edges]
    out: dict[str, JSONValue] = {}
    for key, rs, worlds, cfg in _level_methods(folder, rows):
        ks = range(cfg.k_min, cfg.k_max + 1)
        chosen = {w: _smallest_k([r for r in rs if r[0] != w], ks, target) for w in worlds}
        labels = [_label(edges[i], edges[i + 1]) for i in range(len(edges) - 1)]
        tally = {lab: [0, 0, 0] for lab in [*labels, "all"]}
        groups: dict[str, dict[tuple[str, str], list[int]]] = {lab: {} for lab in tally}
        for r in rs:
            k = chosen[r[0]]
            pos = k is not None and r[4] >= k
            b = heading_bin(r[5], edges)
            for lab in ([labels[b]] if b >= 0 else []) + ["all"]:
                hit, false, rel = int(pos and r[2] and r[3]), int(pos and not r[3]), int(r[2])
                tally[lab][0] += hit
                tally[lab][1] += false
                tally[lab][2] += rel
                g = groups[lab].setdefault((r[0], r[1]), [0, 0, 0])
                g[0] += hit
                g[1] += false
                g[2] += rel
        intervals: dict[str, JSONValue] = {}
        per_world: dict[str, JSONValue] = {}
        for lab, (tp, fp, rel) in tally.items():
            gs = groups[lab]
            # per world (sorted): held-out hits, false positives, relevant pairs
            cols = [[sum(v[i] for (w, _), v in gs.items() if w == world) for world in worlds] for i in range(3)]
            rec_ci = world_boot(cols[0], cols[2], decide_at=0.1, half_width=True) if rel else None
            prec_ci = world_boot(cols[0], [h + f for h, f in zip(cols[0], cols[1], strict=True)]) if tp + fp else None
            intervals[lab] = {
                "recall_wilson": wilson_interval(tp, rel, BOOT_LEVEL),
                "recall_worlds": None if rec_ci is None else [rec_ci["low"], rec_ci["high"]],
                "precision_worlds": None if prec_ci is None else [prec_ci["low"], prec_ci["high"]],
            }
            per_world[lab] = cols
        out[key] = {"thresholds": chosen, "bins": tally, "intervals": intervals, "worlds": per_world}
    return out


def benchmark_verdicts(held: Mapping[str, JSONValue]) -> dict[str, JSONValue]:
    """Per ``level|bin|a|b`` (methods in sorted order) the paired verdict of their held-out hits per world, and
    per ``level|bin`` the floor: the methods with fewer than ``FLOOR_HITS`` held-out hits there."""
    by_level: dict[str, dict[str, dict]] = {}
    for key, fig in held.items():
        level, method = key.split("|", 1)
        if not isinstance(fig, dict):
            raise StorageError(f"held-out figures of {key}: not a mapping")
        by_level.setdefault(level, {})[method] = fig
    out: dict[str, JSONValue] = {}
    for level, methods in by_level.items():
        names = sorted(methods)
        for lab in methods[names[0]]["worlds"]:
            cols = {m: methods[m]["worlds"][lab] for m in names}
            out[f"{level}|{lab}"] = [m for m in names if sum(cols[m][0]) < FLOOR_HITS]
            for i, a in enumerate(names):
                for b in names[i + 1 :]:
                    out[f"{level}|{lab}|{a}|{b}"] = paired_verdict(cols[a][0], cols[b][0], cols[a][2])
    return out


def benchmark_deployable_widths(held: Mapping[str, JSONValue]) -> dict[str, dict[str, float | None]]:
    """Per level, per heading bin (not ``all``) the widest world-bootstrap half-width of held-out recall over the
    methods with at least ``FLOOR_HITS`` held-out hits there, from ``benchmark_held_out``'s figures (None where
    no such method has relevant pairs in the bin)."""
    out: dict[str, dict[str, float | None]] = {}
    for key, fig in held.items():
        level = key.split("|", 1)[0]
        if not isinstance(fig, dict) or not isinstance(fig["intervals"], dict) or not isinstance(fig["bins"], dict):
            raise StorageError(f"held-out figures of {key}: not a mapping")
        bins = out.setdefault(level, {})
        for lab, iv in fig["intervals"].items():
            if lab == "all" or not isinstance(iv, dict):
                continue
            ci = iv["recall_worlds"]
            floor = fig["bins"][lab][0] < FLOOR_HITS  # type: ignore[index, operator]
            half = (float(ci[1]) - float(ci[0])) / 2 if isinstance(ci, list) and not floor else None  # type: ignore[arg-type]
            prev = bins.get(lab)
            bins[lab] = half if prev is None else (prev if half is None else max(prev, half))
    return out


def benchmark_floor_bins(held: Mapping[str, JSONValue]) -> list[tuple[str, str]]:
    """(level, heading bin) where every method has fewer than ``FLOOR_HITS`` held-out hits (``all`` aside)."""
    below: dict[tuple[str, str], bool] = {}
    for key, fig in held.items():
        level = key.split("|", 1)[0]
        for lab, counts in fig["bins"].items():  # type: ignore[index, union-attr]
            if lab != "all":
                below[(level, lab)] = below.get((level, lab), True) and counts[0] < FLOOR_HITS
    return sorted(k for k, v in below.items() if v)


def benchmark_deployable_bound_met(
    folder: str | Path,
    widths: Mapping[str, Mapping[str, float | None]],
    bound: float = 0.1,
    floors: Sequence[tuple[str, str]] = (),
) -> bool:
    """Whether every cell of ``benchmark.json`` finished, every level has held-out figures in every heading
    bin and each bin's widest world-bootstrap half-width (``benchmark_deployable_widths``) is at most ``bound``;
    ``floors`` (every method below the floor) hold no bound."""
    rec = json.loads((Path(folder) / "benchmark.json").read_text(encoding="utf-8"))
    n_bins = len(rec["heading_edges_deg"]) - 1
    if any(c["status"] != "ok" for c in rec["cells"]):
        return False
    levels = [lv["name"] for lv in rec["levels"]]
    return all(
        len(widths.get(lv, {})) == n_bins
        and all((lv, h) in floors or (w is not None and w <= bound) for h, w in widths[lv].items())
        for lv in levels
    )


def _area_by_hand(points: Sequence[tuple[float, float]]) -> float | None:
    """Area under precision over recall of ``(recall, precision)`` points: at each recall the best precision,
    the curve begun at recall 0 with the precision of its lowest recall, trapezoids between (None: no point)."""
    best: dict[float, float] = {}
    for r, p in points:
        best[r] = max(p, best.get(r, p))
    if not best:
        return None
    xs = sorted(best)
    curve = ([(0.0, best[xs[0]])] if xs[0] > 0 else []) + [(x, best[x]) for x in xs]
    return sum((x2 - x1) * (y1 + y2) / 2 for (x1, y1), (x2, y2) in zip(curve, curve[1:], strict=False))


def _curve_points(tp: F64, fp: F64, rel: float) -> list[tuple[float, float]]:
    """(recall, precision) at each threshold with a positive, given pooled counts (none without a relevant pair)."""
    if rel <= 0:
        return []
    return [(float(t) / rel, float(t) / float(t + f)) for t, f in zip(tp, fp, strict=True) if t + f > 0]


def benchmark_pr_areas(folder: str | Path, draws: int = 4000, seed: int = 0) -> dict[str, JSONValue]:
    """Per ``level|method``: the area under the precision-recall curve on the association count (every k of
    the sweep; the cross-robot pairs of every heading pooled over the level's worlds) as ``auc``, and its world
    bootstrap interval as ``auc_worlds``: ``draws`` draws of the level's worlds with replacement
    (``numpy.random.default_rng(seed).integers(0, n, (draws, n))``), each drawn world's pairs whole, the area of
    each draw's pooled curve (a draw without a relevant pair left out), the 2.5 and 97.5 % quantiles."""
    folder = Path(folder)
    out: dict[str, JSONValue] = {}
    for key, rs, worlds, cfg in _level_methods(folder, _benchmark_rows(folder)[1]):
        ks = range(cfg.k_min, cfg.k_max + 1)
        at = {w: i for i, w in enumerate(worlds)}
        tp, fp, rel = np.zeros((len(worlds), len(ks))), np.zeros((len(worlds), len(ks))), np.zeros(len(worlds))
        for r in rs:
            reach = max(0, min(r[4] - cfg.k_min + 1, len(ks)))  # the thresholds k <= associations
            if r[2] and r[3]:
                tp[at[r[0]], :reach] += 1
            if not r[3]:
                fp[at[r[0]], :reach] += 1
            rel[at[r[0]]] += r[2]
        auc = _area_by_hand(_curve_points(tp.sum(axis=0), fp.sum(axis=0), float(rel.sum())))
        picks = np.random.default_rng(seed).integers(0, len(worlds), (draws, len(worlds)))
        areas = [
            a
            for pick in picks
            if (a := _area_by_hand(_curve_points(tp[pick].sum(axis=0), fp[pick].sum(axis=0), float(rel[pick].sum()))))
            is not None
        ]
        lo, hi = np.quantile(np.asarray(areas), [(1 - BOOT_LEVEL) / 2, 1 - (1 - BOOT_LEVEL) / 2]) if areas else (0, 0)
        own = [_area_by_hand(_curve_points(tp[w], fp[w], float(rel[w]))) for w in range(len(worlds))]
        out[key] = {
            "auc": auc,
            "auc_worlds": [float(lo), float(hi)] if areas else None,
            "world_auc": own,  # each world's own curve's area, in the level's world order
            "max_hits": int(tp.sum(axis=0).max()) if len(ks) else 0,
        }
    return out


def benchmark_auc_verdicts(areas: Mapping[str, JSONValue]) -> dict[str, JSONValue]:
    """Per ``level|a|b`` (names sorted): the paired verdict on the area under the curve as the benchmark states
    it: over the worlds where both have an area, each world's difference rounded to 0.001, the exact two-sided
    sign-flip p-value; ``a ahead`` / ``b ahead`` at p <= 0.05 with a non-zero summed difference, ``too few
    hits`` where both reach fewer than ``FLOOR_HITS`` hits at their loosest threshold; ``diff`` the mean of the
    unrounded differences."""
    per: dict[str, dict[str, Mapping[str, Any]]] = {}
    for key, v in areas.items():
        level, method = key.split("|", 1)
        assert isinstance(v, dict)
        per.setdefault(level, {})[method] = v
    out: dict[str, JSONValue] = {}
    for level, methods in per.items():
        names = sorted(methods)
        for i, a in enumerate(names):
            for b in names[i + 1 :]:
                xa, xb = methods[a], methods[b]
                both = [(x, y) for x, y in zip(xa["world_auc"], xb["world_auc"], strict=True) if None not in (x, y)]
                steps = [round((x - y) * 1000) for x, y in both]
                p = sign_flip_p_value(steps) if steps else 1.0
                if xa["max_hits"] < FLOOR_HITS and xb["max_hits"] < FLOOR_HITS:
                    verdict = "too few hits"
                elif steps and p <= 1 - BOOT_LEVEL and sum(steps) != 0:
                    verdict = "a ahead" if sum(steps) > 0 else "b ahead"
                else:
                    verdict = "no difference shown"
                diff = sum(x - y for x, y in both) / len(both) if both else None
                out[f"{level}|{a}|{b}"] = {"verdict": verdict, "diff": diff, "p_value": p, "worlds": len(both)}
    return out


#: The benchmark's one-new-world precision spread, as its documentation states the fit: each world's held-out
#: precision a draw of Beta(a, b), its hits out of its accepted pairs BetaBinomial(n, a, b); maximum likelihood
#: over the worlds that accepted a pair (two at least), the mean a / (a + b) and the concentration a + b kept in
#: these bounds; the stated interval the central 95 % of Beta(a, b).
SPREAD_MEAN, SPREAD_CONCENTRATION, SPREAD_LEVEL = (1e-4, 1 - 1e-4), (1e-2, 1e5), 0.95


def beta_binomial_loglik(a: float, b: float, hits: Sequence[int], accepted: Sequence[int]) -> float:
    """The log-likelihood of per-world ``hits`` out of ``accepted`` pairs under BetaBinomial(n, a, b)."""
    from scipy.stats import betabinom

    return float(betabinom.logpmf(np.asarray(hits), np.asarray(accepted), a, b).sum())


def beta_binomial_fit(hits: Sequence[int], accepted: Sequence[int]) -> dict[str, JSONValue] | None:
    """The maximum-likelihood Beta(a, b) of per-world precisions (worlds without an accepted pair left out):
    a grid over the logit of the mean and the log of the concentration within their bounds, then Nelder-Mead
    from its best point; ``a``, ``b``, ``worlds``, ``loglik`` and ``interval`` (the central 95 % of Beta(a, b)).
    None with fewer than two worlds that accepted a pair."""
    from scipy.optimize import minimize
    from scipy.special import expit, logit
    from scipy.stats import beta

    kept = [(int(h), int(n)) for h, n in zip(hits, accepted, strict=True) if n > 0]
    if len(kept) < 2:
        return None
    h, n = [k[0] for k in kept], [k[1] for k in kept]
    lo_m, hi_m = float(logit(SPREAD_MEAN[0])), float(logit(SPREAD_MEAN[1]))
    lo_c, hi_c = math.log(SPREAD_CONCENTRATION[0]), math.log(SPREAD_CONCENTRATION[1])
    box = [(lo_m, hi_m), (lo_c, hi_c)]

    def nll(x: Sequence[float]) -> float:
        m, c = float(expit(x[0])), math.exp(x[1])
        return -beta_binomial_loglik(m * c, (1 - m) * c, h, n)

    grid = [(float(u), float(v)) for u in np.linspace(lo_m, hi_m, 41) for v in np.linspace(lo_c, hi_c, 41)]
    start = min(grid, key=nll)
    res = minimize(nll, start, method="Nelder-Mead", bounds=box, options={"xatol": 1e-9, "fatol": 1e-12})
    x = res.x if res.fun <= nll(start) else start
    m, c = float(expit(x[0])), math.exp(x[1])
    a, b = m * c, (1 - m) * c
    tail = (1 - SPREAD_LEVEL) / 2
    return {
        "a": a,
        "b": b,
        "worlds": len(kept),
        "loglik": beta_binomial_loglik(a, b, h, n),
        "interval": [float(v) for v in beta.ppf([tail, 1 - tail], a, b)],
    }


def benchmark_precision_spreads(held: Mapping[str, JSONValue]) -> dict[str, JSONValue]:
    """Per ``level|method`` the one-new-world precision spread (``beta_binomial_fit``) of each world's held-out
    hits out of its accepted pairs (hits and false positives) over all headings, from ``benchmark_held_out``'s
    figures, with each world's ``hits`` and ``accepted``."""
    out: dict[str, JSONValue] = {}
    for key, fig in held.items():
        cols = fig["worlds"]["all"]  # type: ignore[index, call-overload]
        hits, accepted = [int(x) for x in cols[0]], [int(x) + int(y) for x, y in zip(cols[0], cols[1], strict=True)]
        out[key] = {"hits": hits, "accepted": accepted, "fit": beta_binomial_fit(hits, accepted)}
    return out


#: A fresh precision counts as holding the target when at most this far below it (nothing accepted: held).
CHECK_SLACK = Fraction(5, 100)


def _fresh_counts(
    rows: Sequence[BenchRow], k: int | None, worlds: Sequence[str], edges: Sequence[float]
) -> dict[str, list[list[int]]]:
    """Per heading bin (and ``all``) and per world (in ``worlds``' order) [hits, false positives, relevant] of
    rows judged at threshold ``k`` (None: nothing accepted)."""
    labels = [_label(edges[i], edges[i + 1]) for i in range(len(edges) - 1)]
    out = {lab: [[0, 0, 0] for _ in worlds] for lab in [*labels, "all"]}
    at = {w: i for i, w in enumerate(worlds)}
    for r in rows:
        pos = k is not None and r[4] >= k
        b = heading_bin(r[5], edges)
        for lab in ([labels[b]] if b >= 0 else []) + ["all"]:
            c = out[lab][at[r[0]]]
            c[0] += int(pos and r[2] and r[3])
            c[1] += int(pos and not r[3])
            c[2] += int(r[2])
    return out


def benchmark_check(board: str | Path, fresh: str | Path) -> dict[str, JSONValue]:
    """A board's check on fresh worlds, re-derived from the raw files: ``board`` the board's folder, ``fresh``
    the check's folder (its fresh cells). Per ``level|method``: the deployed threshold ``k`` (the smallest k of
    the sweep whose precision over every board world of the level reaches the board's target), the fresh
    worlds' pooled ``hits`` and ``false_positives`` at ``k``, ``precision``, ``target_held`` (at most
    ``CHECK_SLACK`` below the target, or nothing accepted) and per fresh world its ``hits``, ``accepted`` and,
    against the Beta(a, b) the board states (``leaderboard.json``), ``hits_interval`` (the central 95 % of
    BetaBinomial(accepted, a, b)) and ``inside``. Per ``level|heading|a|b`` of each verdict the board states
    ("a ahead" / "b ahead"): the fresh ``hits_a``, ``hits_b``, ``relevant``, whether the stated sign ``held``
    and the same exact test on the fresh worlds (``paired_verdict``)."""
    from scipy.stats import betabinom

    board, fresh = Path(board), Path(fresh)
    lb = json.loads((board / "leaderboard.json").read_text(encoding="utf-8"))
    target = Fraction(str(lb["target_precision"]))
    _, board_rows = _benchmark_rows(board)
    _, fresh_rows = _benchmark_rows(fresh)
    rec = json.loads((fresh / "benchmark.json").read_text(encoding="utf-8"))
    edges = [float(e) for e in rec["heading_edges_deg"]]
    out: dict[str, JSONValue] = {}
    for e in lb["levels"]:
        d = e.get("deployable") or {}
        if d.get("note") is not None or d.get("deployed") is None:
            continue
        worlds = sorted(c["id"] for c in rec["cells"] if c["level"] == e["name"] and c["status"] == "ok")
        counts: dict[str, dict[str, list[list[int]]]] = {}
        for m in d["deployed"]:
            own = board_rows.get(f"{e['name']}|{m}", [])
            if not own or not fresh_rows.get(f"{e['name']}|{m}"):
                continue  # no pair of the method on the board's or on the fresh worlds: nothing to check
            cfg = read_settings(board / "cells" / own[0][0])
            k = _smallest_k(own, range(cfg.k_min, cfg.k_max + 1), target)
            counts[m] = _fresh_counts(fresh_rows.get(f"{e['name']}|{m}", []), k, worlds, edges)
            spread = (d.get("spread") or {}).get(m)
            per: dict[str, JSONValue] = {}
            for w, (h, f, _) in zip(worlds, counts[m]["all"], strict=True):
                iv = None
                if spread is not None and h + f:
                    iv = [int(x) for x in betabinom.ppf([0.025, 0.975], h + f, spread["a"], spread["b"])]
                per[w] = {
                    "hits": h,
                    "accepted": h + f,
                    "hits_interval": iv,
                    "inside": None if iv is None else iv[0] <= h <= iv[1],
                }
            tp, fp = sum(c[0] for c in counts[m]["all"]), sum(c[1] for c in counts[m]["all"])
            held = tp + fp == 0 or Fraction(tp, tp + fp) >= target - CHECK_SLACK
            out[f"{e['name']}|{m}"] = {
                "k": k,
                "hits": tp,
                "false_positives": fp,
                "precision": tp / (tp + fp) if tp + fp else None,
                "target_held": held,
                "worlds": per,
            }
        for cell in [*d["bins"], d["overall"]]:
            for v in cell["verdicts"]:
                if v["verdict"] not in ("a ahead", "b ahead") or v["a"] not in counts or v["b"] not in counts:
                    continue
                a, b = counts[v["a"]][cell["heading"]], counts[v["b"]][cell["heading"]]
                ha, hb, rel = [x[0] for x in a], [x[0] for x in b], [x[2] for x in a]
                sign = 1 if v["verdict"] == "a ahead" else -1
                test = paired_verdict(ha, hb, rel) if len(worlds) >= 2 else None
                out[f"{e['name']}|{cell['heading']}|{v['a']}|{v['b']}"] = {
                    "hits_a": sum(ha),
                    "hits_b": sum(hb),
                    "relevant": sum(rel),
                    "held": sign * (sum(ha) - sum(hb)) > 0 if sum(rel) else None,
                    "fresh": test,
                }
    return out


# -- the attribution study ------------------------------------------------------------------------
def newcombe_interval(k1: int, n1: int, k2: int, n2: int, level: float) -> list[float] | None:
    """Newcombe's hybrid-score interval of k1/n1 - k2/n2 from the two Wilson intervals; None without pairs."""
    a, b = wilson_interval(k1, n1, level), wilson_interval(k2, n2, level)
    if a is None or b is None:
        return None
    p1, p2 = k1 / n1, k2 / n2
    lower = p1 - p2 - math.sqrt((p1 - a[0]) ** 2 + (b[1] - p2) ** 2)
    upper = p1 - p2 + math.sqrt((a[1] - p1) ** 2 + (p2 - b[0]) ** 2)
    return [lower, upper]


def world_drop_interval(
    same: Sequence[tuple[int, int]], opposite: Sequence[tuple[int, int]], picks: Sequence[Sequence[int]], level: float
) -> list[float] | None:
    """Percentile interval of the pooled drop over resampled worlds, written out:

    for each resample in ``picks`` (a list of world indices, repeats allowed), add up the drawn
    worlds' same-direction (hits, relevant) and opposite-direction (hits, relevant); skip it if
    either relevant total is 0, else keep hits_s / relevant_s - hits_o / relevant_o. Return the
    (1 - level) / 2 and (1 + level) / 2 quantiles of the kept values (linear interpolation
    between order statistics at position q * (n - 1)); None when none is kept.
    """
    kept = []
    for pick in picks:
        hs = sum(same[i][0] for i in pick)
        ns = sum(same[i][1] for i in pick)
        ho = sum(opposite[i][0] for i in pick)
        no = sum(opposite[i][1] for i in pick)
        if ns and no:
            kept.append(hs / ns - ho / no)
    if not kept:
        return None
    kept.sort()

    def quantile(q: float) -> float:
        pos = q * (len(kept) - 1)
        i = math.floor(pos)
        j = min(i + 1, len(kept) - 1)
        return kept[i] + (pos - i) * (kept[j] - kept[i])

    tail = (1 - level) / 2
    return [quantile(tail), quantile(1 - tail)]


def world_resamples(n_worlds: int, draws: int, seed: int) -> list[list[int]]:
    """The study's resamples of worlds: ``numpy.random.default_rng(seed)`` draws a (draws, n_worlds)
    table of integers in [0, n_worlds), one row per resample (worlds indexed by sorted seed)."""
    table = np.random.default_rng(seed).integers(0, n_worlds, size=(draws, n_worlds))
    return [[int(x) for x in row] for row in table]


def attribution_rows(folder: str | Path) -> list[dict[str, JSONValue]]:
    """The attribution table re-derived from a study folder's raw pairs.

    Reads ``attribution.json`` (its methods, mechanisms, world seeds and runs) and, per run under
    ``runs/``, the cross-robot rows of each method at the ``max_recall`` operating point: hits,
    relevant pairs and false positives; sums them over the worlds per role, mechanism and method;
    then per mechanism and method the drop same - opposite with Newcombe's interval, with two or
    more worlds the world-bootstrap interval of the pooled drop (``world_drop_interval`` over
    ``world_resamples``), and the share of the all-on (``none``) drop that is gone with the
    mechanism off.
    """
    d = Path(folder)
    with _open_text(d / "attribution.json") as fh:
        spec = json.load(fh)
    conf = spec["config"]
    methods, level = list(conf["methods"]), float(conf["level"])
    per_world: dict[tuple[str, str, str], dict[int | None, tuple[int, int, int]]] = {}
    for run in spec["runs"]:
        cfg, pairs, judged = judged_rows(d / "runs" / run["run"])
        for m in methods:
            rows = [j for p, j in zip(pairs, judged) if p.method == m and p.kind == "inter"]
            pt = operating_points(rows, cfg)["max_recall"]
            assert isinstance(pt, dict)
            per_world.setdefault((run["role"], run["mechanism"], m), {})[run.get("seed")] = (
                int(pt["hits"]),
                int(pt["n_relevant"]),
                int(pt["false_positives"]),
            )
    seeds = sorted(conf["seeds"]) if conf.get("seeds") else [None]
    picks = world_resamples(len(seeds), int(conf["boot_draws"]), int(conf["boot_seed"])) if len(seeds) >= 2 else None
    out: list[dict[str, JSONValue]] = []
    for mech in ["none", *conf["mechanisms"]]:
        for m in methods:
            row: dict[str, JSONValue] = {"mechanism": mech, "method": m, "worlds": len(seeds)}
            worlds = {role: [per_world[(role, mech, m)][w] for w in seeds] for role in ("same", "opposite")}
            counts = {role: tuple(sum(c[i] for c in worlds[role]) for i in range(3)) for role in worlds}
            for role in ("same", "opposite"):
                hits, rel, fp = counts[role]
                ci = wilson_interval(hits, rel, level)
                row[f"{role}_hits"], row[f"{role}_relevant"] = hits, rel
                row[f"{role}_recall"] = hits / rel if rel else None
                row[f"{role}_recall_lo"], row[f"{role}_recall_hi"] = (None, None) if ci is None else (ci[0], ci[1])
                row[f"{role}_precision"] = hits / (hits + fp) if hits + fp else None
            (hs, ns, _), (ho, no, _) = counts["same"], counts["opposite"]
            nc = newcombe_interval(hs, ns, ho, no, level)
            row["drop"] = None if nc is None else hs / ns - ho / no
            row["drop_lo"], row["drop_hi"] = (None, None) if nc is None else (nc[0], nc[1])
            boot = None
            if picks is not None and nc is not None:
                boot = world_drop_interval(
                    [(c[0], c[1]) for c in worlds["same"]], [(c[0], c[1]) for c in worlds["opposite"]], picks, level
                )
            row["drop_worlds_lo"], row["drop_worlds_hi"] = (None, None) if boot is None else (boot[0], boot[1])
            out.append(row)
    for row in out:
        base = next(r["drop"] for r in out if r["mechanism"] == "none" and r["method"] == row["method"])
        drop = row["drop"]
        ok = isinstance(base, float) and isinstance(drop, float) and base > 0
        row["explained"] = (base - drop) / base if ok else None  # type: ignore[operator]
    return out


# -- the paper preset's fit and predictions ----------------------------------------------------
#: The paper's held-out figures the preset's claims test: ROMAN's opposite-direction max recall
#: 0.26 +- 0.08, and the same/opposite ratio band that this gives around 2.6 (target / 0.34 to
#: target / 0.18); the ordering's methods, best first; the level of the admitting intervals.
PAPER_OPPOSITE = (Fraction(26, 100), Fraction(8, 100))
PAPER_ORDER = ("roman", "ransac1m", "clipper")
ADMIT_LEVEL = 0.95


def _inter_counts(run_dir: Path, methods: Sequence[str]) -> dict[str, tuple[int, int]]:
    """Per method, (max hits, relevant) over the cross-robot rows of a run, from its raw pairs."""
    cfg, pairs, judged = judged_rows(run_dir)
    out = {}
    for m in methods:
        rows = [j for p, j in zip(pairs, judged) if p.method == m and p.kind == "inter"]
        out[m] = (_max_hits(rows, cfg), sum(r.relevant for r in rows))
    return out


def _paper_verdict(holds: Sequence[bool], not_run: int) -> str:
    """some: the settings run disagree; undetermined: they agree but some were not run; else every / none."""
    if any(holds) and not all(holds):
        return "some"
    if not_run:
        return "undetermined"
    return "every" if holds and all(holds) else "none"


def paper_preset_figures(folder: str | Path) -> dict[str, JSONValue]:
    """The paper preset's admitted settings and its three predictions, re-derived from the raw pairs.

    From ``fit_state.json`` only the fit's configuration is read (``scenario``,
    ``predict_scenario``, ``method``, ``target``). Every fit run is a folder
    ``runs/<scenario>_<severity, 6 decimals>``; its ``method``'s cross-robot max hits and
    relevant pairs come from its pairs and alignments. The fitted severity is the one whose
    recall lies closest to the target (the lower on a tie); the admitted ones are those whose
    95 % Wilson interval contains the target, and the fitted one. A severity's prediction run is
    ``runs/<predict_scenario>_<severity>``; a folder made before the admitted settings has one
    prediction run, ``runs/<predict_scenario>``, at the fitted severity. Per claim and admitted
    severity: the value (None when not run) and whether it holds; the range over the settings
    run; the verdict (``every``, ``some``, ``none``, or ``undetermined`` when some setting was
    not run and those run agree).
    """
    d = Path(folder)
    with _open_text(d / "fit_state.json") as fh:
        spec = json.load(fh)["config"]
    scenario, predict, method = str(spec["scenario"]), str(spec["predict_scenario"]), str(spec["method"])
    target = float(spec["target"])
    prefix = f"{scenario}_"
    fit: dict[float, tuple[int, int]] = {}
    for run in sorted((d / "runs").iterdir()):
        if run.is_dir() and run.name.startswith(prefix):
            fit[float(run.name[len(prefix) :])] = _inter_counts(run, [method])[method]
    scored = [(s, k / n) for s, (k, n) in fit.items() if n]
    fitted = min(scored, key=lambda sr: (abs(sr[1] - target), sr[0]))[0]
    admitted = []
    for s, (k, n) in sorted(fit.items()):
        ci = wilson_interval(k, n, ADMIT_LEVEL)
        if s == fitted or (ci is not None and ci[0] <= target <= ci[1]):
            admitted.append(s)
    centre, band = PAPER_OPPOSITE
    lo, hi = float(centre - band), float(centre + band)
    rows: dict[str, dict[float, tuple[JSONValue, bool] | None]] = {"opposite": {}, "ordering": {}, "ratio": {}}
    predicted: dict[float, dict[str, tuple[int, int]]] = {}
    for s in admitted:
        run = d / "runs" / f"{predict}_{s:.6f}"
        if not run.is_dir() and s == fitted and (d / "runs" / predict).is_dir():
            run = d / "runs" / predict
        if not run.is_dir():
            for claim in rows.values():
                claim[s] = None
            continue
        got = predicted[s] = _inter_counts(run, PAPER_ORDER)
        rec = {m: k / n if n else None for m, (k, n) in got.items()}
        r = rec[method]
        rows["opposite"][s] = (r, r is not None and lo <= r <= hi)
        vals = [rec[m] for m in PAPER_ORDER]
        ordered = all(v is not None for v in vals) and vals[0] > vals[1] > vals[2]  # type: ignore[operator]
        rows["ordering"][s] = (rec, ordered)
        k, n = fit[s]
        q = (k / n) / r if n and r else None
        rows["ratio"][s] = (q, q is not None and target / hi <= q <= target / lo)
    claims: dict[str, JSONValue] = {}
    for name, per in rows.items():
        ran = {s: v for s, v in per.items() if v is not None}
        holds = [h for _, h in ran.values()]
        if name == "ordering":
            span: JSONValue = {
                m: [min(vs), max(vs)] if vs else None
                for m in PAPER_ORDER
                for vs in [[v[m] for v, _ in ran.values() if isinstance(v, dict) and v[m] is not None]]
            }
        else:
            nums = [v for v, _ in ran.values() if isinstance(v, float)]
            span = [min(nums), max(nums)] if nums else None
        claims[name] = {
            "values": {s: None if v is None else v[0] for s, v in per.items()},
            "holds": {s: v[1] for s, v in ran.items()},
            "range": span,
            "verdict": _paper_verdict(holds, len(per) - len(ran)),
        }
    return {
        "fit": {s: {"hits": k, "relevant": n, "ci": wilson_interval(k, n, ADMIT_LEVEL)} for s, (k, n) in fit.items()},
        "fitted": fitted,
        "admitted": admitted,
        "predicted": {s: {m: {"hits": k, "relevant": n} for m, (k, n) in v.items()} for s, v in predicted.items()},
        "claims": claims,
    }
