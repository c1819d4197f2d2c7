"""Score any system's loop closures (and trajectories) against a run's truth, as a run of its own.

``score_external(source, closures, out)`` takes a finished run folder, or an export folder
(its ``config.yaml`` is the scenario: the run's maps and submaps are computed first, the
same as ``roman-sim run`` of it gives), and a closure file (``roman_sim.interop.closures``:
g2o or CSV). Each closure end ``(robot, t)`` is matched to that robot's submap whose centre
time is nearest to ``t``, and the closure's relative body pose becomes an estimate of the
pair's ``T_a_b`` through the run's odometry::

    T_a_b = inv(T_odom_submap_a) @ T_odom_body_a(t_a) @ T_pa_pb @ inv(T_odom_body_b(t_b)) @ T_odom_submap_b

(the body poses at the closure times are the odometry's, interpolated between frames).
The closures then go through the run's own evaluation as one more method, named
``label`` (``roman_sim.align.closure_table``): the same pairs, truth, correctness,
recall against heading and ambiguity at every operating point, precision, the pose graph
with its closures and the ATE table, the report and the plots, in a new run folder ``out``.
A closure's score is its association count; a closure without one gets the run's
acceptance threshold (``posegraph.lc_association_thresh``), so it counts as accepted.
Closures of the same pair keep the highest score; closures whose two ends fall in one
submap, or on a pair the evaluation does not score (same-robot neighbours), are listed as
unscored. With ``trajectories`` (one ``<robot>.tum`` per robot), the system's own
trajectories are scored too (``external_ate.json``, one SE(3)/4-DoF fit over all robots).

Bad input (unknown robot, a time outside the run, a malformed line, a non-rigid pose,
trajectories that do not cover the run) raises ``ConfigError`` naming the file and line
before anything is written. ``external.json`` records what was read and matched, and the
report starts with a section that marks the method as an external system.
"""

from __future__ import annotations

import logging
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation, Slerp

from roman_sim.align.closure_table import METHOD, TABLE_FORMAT, ClosureTable, TableRow, table_sha256
from roman_sim.core.atomic import write_text
from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.geometry import inv_T
from roman_sim.core.records import read_record, write_record
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum
from roman_sim.evaluation.atetable import ATE_SCHEMA, AteTable, TrajectoryVariant, ate_table
from roman_sim.evaluation.pairs import select_pairs
from roman_sim.interop.base import EXPORT_JSON, read_export_manifest
from roman_sim.interop.closures import Closure, read_closures, read_pose_csv
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.context import Progress, RunContext
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.manifest import MANIFEST_JSON, Manifest, StageRecord, existing_manifest
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import Scenario, load_scenario
from roman_sim.pipeline.stages.maps import MapsStage
from roman_sim.pipeline.stages.submaps import SubmapsStage

log = logging.getLogger(__name__)

TABLE_JSON = "external_closures.json"
EXTERNAL_JSON = "external.json"
EXTERNAL_ATE_JSON = "external_ate.json"
#: A closure time may lie this far outside the robot's frames (s).
TIME_TOL_S = 1e-3
#: A trajectory must start and end within this of the robot's first and last frame (s).
COVER_TOL_S = 1.0
_EXACT_S = 1e-6  # a closure time this close to a frame's is that frame


@dataclass
class ExternalScore:
    """What ``score_external`` produced.

    Attributes:
        run: the scored run (the external method is its only aligner).
        label: the method's name in tables.
        n_closures: loop closures read.
        n_pairs: submap pairs that received an estimate.
        unscored: closure line -> why it was not scored.
        trajectories_ate: the system's own trajectories scored (None without ``trajectories``).
    """

    run: RunResult
    label: str
    n_closures: int
    n_pairs: int
    unscored: dict[int, str] = field(default_factory=dict)
    trajectories_ate: AteTable | None = None


def _frame_times(source: Path, scenario: Scenario) -> dict[str, NDArray[np.float64]]:
    """Each robot's frame times: from the run's maps or the export's ``masks.txt``."""
    if (source / MANIFEST_JSON).is_file():
        maps = _load_stage(source, scenario, MapsStage())
        return {r: m.odometry.t for r, m in maps.maps.items()}
    out = {}
    for r in scenario.robots:
        path = source / r.name / "masks.txt"
        if path.is_file():
            rows = [ln.split()[0] for ln in path.read_text(encoding="utf-8").splitlines() if ln and ln[0] != "#"]
            out[r.name] = np.asarray([float(s) for s in rows], dtype=np.float64)
    return out


def _robot_order(source: Path, scenario: Scenario) -> list[str]:
    """The robots in the export's order (those it holds), else the scenario's."""
    if (source / EXPORT_JSON).is_file() and not (source / MANIFEST_JSON).is_file():
        return list(read_export_manifest(source).robots)
    return [r.name for r in scenario.robots]


def _load_stage(run_dir: Path, scenario: Scenario, stage: Any) -> Any:
    man = existing_manifest(run_dir)
    if man is None or stage.name not in man.stages:
        raise StorageError(f"{run_dir}: no {stage.name} stage (is it a finished run folder?)")
    return stage.load(RunContext(scenario, run_dir), man.stages[stage.name].files)


def _check_closures(path: Path, closures: list[Closure], times: dict[str, NDArray[np.float64]]) -> None:
    allowed = ", ".join(times)
    for c in closures:
        for r, t in ((c.robot_a, c.t_a), (c.robot_b, c.t_b)):
            if r not in times:
                raise ConfigError(f"{path}:{c.line}: robot {r!r} is not a robot of the run (allowed: {allowed})")
            ts = times[r]
            if not ts[0] - TIME_TOL_S <= t <= ts[-1] + TIME_TOL_S:
                raise ConfigError(
                    f"{path}:{c.line}: time {t:.6f} s of robot {r} is outside the run "
                    f"(allowed: {ts[0]:.6f} to {ts[-1]:.6f} s)"
                )


def _read_trajectory(folder: Path, robot: str, robots: list[str]) -> tuple[Path, Trajectory]:
    """``<robot>.tum``, else the reference ROMAN's ``<robot>.csv``."""
    for path, reader in ((folder / f"{robot}.tum", read_tum), (folder / f"{robot}.csv", read_pose_csv)):
        if path.is_file():
            try:
                return path, reader(path)
            except StorageError as err:
                raise ConfigError(str(err)) from None
    need = ", ".join(f"{x}.tum" for x in robots)
    raise ConfigError(
        f"--trajectories {folder}: no {robot}.tum or {robot}.csv (one file per robot: {need}, or the reference "
        "ROMAN's <robot>.csv)"
    )


def _read_trajectories(folder: Path, times: dict[str, NDArray[np.float64]]) -> dict[str, Trajectory]:
    """Every robot's trajectory (``_read_trajectory``), each covering the robot's frames (ConfigError otherwise)."""
    if not folder.is_dir():
        raise ConfigError(f"--trajectories {folder}: not a folder")
    out = {}
    for r, ts in times.items():
        path, tr = _read_trajectory(folder, r, list(times))
        if len(tr) < 3 or tr.t[0] > ts[0] + COVER_TOL_S or tr.t[-1] < ts[-1] - COVER_TOL_S:
            span = f"{tr.t[0]:.3f} to {tr.t[-1]:.3f} s" if len(tr) else "no poses"
            raise ConfigError(
                f"{path}: covers {span}; robot {r} runs {ts[0]:.3f} to {ts[-1]:.3f} s (allowed: from at most "
                f"{COVER_TOL_S:g} s after its first frame to at most {COVER_TOL_S:g} s before its last, "
                "3 poses or more)"
            )
        out[r] = tr
    return out


def pose_at(traj: Trajectory, t: float) -> NDArray[np.float64]:
    """The trajectory's pose at ``t``: a frame's own within 1 us, else interpolated (linear, slerp)."""
    i = int(np.argmin(np.abs(traj.t - t)))
    if abs(traj.t[i] - t) <= _EXACT_S or len(traj) == 1:
        return traj.T[i].copy()
    j = int(np.clip(np.searchsorted(traj.t, t), 1, len(traj) - 1))
    t0, t1 = traj.t[j - 1], traj.t[j]
    w = float(np.clip((t - t0) / (t1 - t0), 0.0, 1.0))
    T = np.eye(4)
    T[:3, :3] = Slerp([t0, t1], Rotation.from_matrix(traj.T[j - 1 : j + 1, :3, :3]))([t0 + w * (t1 - t0)]).as_matrix()[
        0
    ]
    T[:3, 3] = (1 - w) * traj.T[j - 1, :3, 3] + w * traj.T[j, :3, 3]
    return T


def _nearest(subs: list[Submap], t: float) -> Submap:
    return min(subs, key=lambda s: (abs(s.t - t), s.index))


@dataclass
class _Resolved:
    pairs: dict[tuple[str, str], tuple[NDArray[np.float64], int, int]]  # (a, b) -> (T_a_b, n, line)
    unscored: dict[int, str]


def resolve(
    closures: list[Closure],
    submaps: dict[str, list[Submap]],
    odometry: dict[str, Trajectory],
    scenario: Scenario,
) -> _Resolved:
    """Each closure as an estimate of one evaluated submap pair (see the module docstring)."""
    every = [s for subs in submaps.values() for s in subs]
    scored = {(a.name, b.name) for a, b in select_pairs(every, scenario.evaluation).pairs}
    k_default = scenario.posegraph.lc_association_thresh
    out = _Resolved({}, {})
    for c in closures:
        sa, sb = _nearest(submaps[c.robot_a], c.t_a), _nearest(submaps[c.robot_b], c.t_b)
        T_sa_sb = (
            inv_T(sa.T_odom_submap)
            @ pose_at(odometry[c.robot_a], c.t_a)
            @ c.T_pa_pb
            @ inv_T(pose_at(odometry[c.robot_b], c.t_b))
            @ sb.T_odom_submap
        )
        if (sa.robot, sa.index) > (sb.robot, sb.index):
            sa, sb, T_sa_sb = sb, sa, inv_T(T_sa_sb)
        key = (sa.name, sb.name)
        n = k_default if c.score is None else int(c.score)
        if sa.name == sb.name:
            out.unscored[c.line] = f"both ends fall in submap {sa.name}"
        elif key not in scored:
            out.unscored[c.line] = f"pair {sa.name}|{sb.name} is not scored by the evaluation (neighbours or capped)"
        elif key in out.pairs and out.pairs[key][1] >= n:
            out.unscored[c.line] = f"pair {sa.name}|{sb.name} already has a closure with a score >= {n}"
        else:
            if key in out.pairs:
                old = out.pairs[key][2]
                out.unscored[old] = f"pair {sa.name}|{sb.name} has a closure with a higher score (line {c.line})"
            out.pairs[key] = (T_sa_sb, n, c.line)
    return out


def _table(res: _Resolved, label: str, source: Path) -> ClosureTable:
    rows = [TableRow(a, b, T.tolist(), n, line) for (a, b), (T, n, line) in sorted(res.pairs.items())]
    return ClosureTable(TABLE_FORMAT, 1, label, str(source), rows)


def _external_scenario(scenario: Scenario, label: str, table: Path, sha: str) -> Scenario:
    data = scenario.model_dump(mode="json")
    data["aligners"] = [{"method": METHOD, "label": label, "params": {"table": str(table), "sha256": sha}}]
    data["posegraph_method"] = label
    data["gating"] = {**data["gating"], "enabled": False}
    return validate_model(Scenario, data, source="external")


def _seed_from_run(source: Path, out: Path) -> None:
    """Copy the run's maps and submaps (and their manifest records) into ``out``, so they are reused."""
    man = existing_manifest(source)
    assert man is not None
    keep: dict[str, StageRecord] = {k: man.stages[k] for k in ("maps", "submaps") if k in man.stages}
    for rec in keep.values():
        for f in rec.files:
            (out / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source / f, out / f)
    Manifest(man.scenario, man.seed, man.config_hash, man.package_version, keep, [], man.environment).save(out)


def _report_section(label: str, closures: Path, n: int, res: _Resolved, ate: AteTable | None) -> str:
    lines = [
        "## External system",
        "",
        f"Method `{label}` is an external system: its loop closures were read from `{closures}` "
        f"({n} closures; {len(res.pairs)} submap pairs received an estimate, {len(res.unscored)} closures unscored), "
        "matched to this run's submaps by time and scored against the truth like every method.",
    ]
    if res.unscored:
        lines += ["", *[f"- line {line}: {why}" for line, why in sorted(res.unscored.items())]]
    if ate is not None:
        lines += ["", "Its own trajectories, ATE RMSE (m), one SE(3) fit over all robots:", ""]
        for name, row in ate.variants.items():
            cells = ", ".join(f"{k} {v:.3f}" for k, v in row.rmse["se3"].items() if v is not None)
            lines.append(f"- {name}: {cells}")
    return "\n".join(lines) + "\n\n"


def score_external(
    source: str | Path,
    closures: str | Path,
    out_dir: str | Path,
    *,
    times: str | Path | None = None,
    robots: Sequence[str] | None = None,
    trajectories: str | Path | None = None,
    label: str = "external",
    progress: Progress | None = None,
) -> ExternalScore:
    """Score an external system's loop closures (and trajectories) on ``source``'s scenario into ``out_dir``.

    Args:
        source: a finished run folder (``manifest.json``) or an export folder (``export.json``).
        closures: a ``.g2o`` or ``.csv`` closure file.
        out_dir: the new run folder (must not hold files).
        times: a g2o file's timestamps file.
        robots: robot order of a g2o file's keys (default: the scenario's robots).
        trajectories: folder of ``<robot>.tum`` trajectories of the system.
        label: the method's name in tables.
        progress: progress sink.
    """
    src, out, path = Path(source), Path(out_dir), Path(closures)
    is_run = (src / MANIFEST_JSON).is_file()
    if not is_run and not (src / EXPORT_JSON).is_file():
        raise ConfigError(f"{src}: neither a run folder (manifest.json) nor an export folder (export.json)")
    if out.exists() and any(out.iterdir()):
        raise ConfigError(f"--out {out}: already holds files (choose a new folder)")
    if not label or "/" in label or ":" in label:
        raise ConfigError(f"--label {label!r}: a non-empty name without '/' or ':'")
    scenario = load_scenario(src / "config.yaml")
    order = list(robots) if robots else _robot_order(src, scenario)
    read = read_closures(path, times, order)
    frame_t = _frame_times(src, scenario)
    _check_closures(path, read, frame_t)
    own = _read_trajectories(Path(trajectories), frame_t) if trajectories is not None else None
    out.mkdir(parents=True, exist_ok=True)
    table = (out / TABLE_JSON).resolve()
    if is_run:
        _seed_from_run(src, out)
    else:  # compute the maps and submaps (their stage outputs are reused by the scoring run)
        write_record(table, ClosureTable(TABLE_FORMAT, 1, label, str(path), []))
        Experiment(_external_scenario(scenario, label, table, table_sha256(table)), out, progress=progress).run()
    maps, subs = _load_stage(out, scenario, MapsStage()), _load_stage(out, scenario, SubmapsStage())
    res = resolve(read, subs.submaps, {r: m.odometry for r, m in maps.maps.items()}, scenario)
    write_record(table, _table(res, label, path))
    sc = _external_scenario(scenario, label, table, table_sha256(table))
    run = Experiment(sc, out, progress=progress).run()
    ate = None
    if own is not None:
        truth = {r: m.truth for r, m in maps.maps.items() if m.truth is not None}
        name = f"{label}_trajectories"
        ate = ate_table(truth, {name: TrajectoryVariant(f"{label}'s own trajectories", "joint", name)}, {name: own})
        write_record(out / EXTERNAL_ATE_JSON, ate.record(), ATE_SCHEMA)
    info = ExternalRecord(
        format="roman_sim.external_score",
        version=1,
        label=label,
        source=str(src),
        closures=str(path),
        times=None if times is None else str(times),
        robots=order,
        trajectories=None if trajectories is None else str(trajectories),
        n_closures=len(read),
        n_pairs=len(res.pairs),
        unscored={str(k): v for k, v in sorted(res.unscored.items())},
    )
    write_record(out / EXTERNAL_JSON, info)
    report = out / "report.md"
    text = report.read_text(encoding="utf-8")
    head, _, rest = text.partition("\n\n")
    write_text(report, f"{head}\n\n{_report_section(label, path, len(read), res, ate)}{rest}")
    log.info("scored %d closures of %s: %d pairs", len(read), label, len(res.pairs))
    return ExternalScore(run, label, len(read), len(res.pairs), dict(res.unscored), ate)


def run_closures(run_dir: str | Path, method: str) -> list[Closure]:
    """A run's own loop closures of ``method`` as an external system reports them (every estimate with a pose).

    Each closure joins the bodies at the two submaps' centre times; its score is the
    association count. Results without a pose (too few associations for a transform) are
    not closures and are left out.
    """
    from roman_sim.pipeline.stages.evaluation import EvaluationStage

    src = Path(run_dir)
    scenario = load_scenario(src / "config.yaml")
    maps, subs = _load_stage(src, scenario, MapsStage()), _load_stage(src, scenario, SubmapsStage())
    ev = _load_stage(src, scenario, EvaluationStage())
    by_name, odom = subs.by_name(), {r: m.odometry for r, m in maps.maps.items()}
    out = []
    for rec in ev.alignments:
        if rec.method != method or rec.T_a_b is None:
            continue
        sa, sb = by_name[rec.a], by_name[rec.b]
        T = (
            inv_T(pose_at(odom[sa.robot], sa.t))
            @ sa.T_odom_submap
            @ np.asarray(rec.T_a_b, dtype=np.float64)
            @ inv_T(sb.T_odom_submap)
            @ pose_at(odom[sb.robot], sb.t)
        )
        out.append(Closure(sa.robot, float(sa.t), sb.robot, float(sb.t), T, int(rec.n_associations)))
    return out


@dataclass(frozen=True)
class ExternalRecord:
    """``external.json``: what was scored (the source folder, the closures and their times, the robot
    order, the system's own trajectories), the closures read, the pairs estimated and why the others
    were not scored (by line of the closures file)."""

    format: str
    version: int
    label: str
    source: str
    closures: str
    times: str | None
    robots: list[str]
    trajectories: str | None
    n_closures: int
    n_pairs: int
    unscored: dict[str, str]


def read_external(run_dir: str | Path) -> ExternalRecord:
    """``external.json`` of a scored folder (RecordError naming the file and field when malformed)."""
    return read_record(Path(run_dir) / EXTERNAL_JSON, ExternalRecord)
