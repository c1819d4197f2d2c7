"""Score any system's loop closures (and trajectories) against a run's truth, as a run of its own.

``score_external(source, closures, out)`` takes a finished run folder, or an export folder
(its ``config.yaml`` is the scenario: the run's maps and submaps are computed first, the
same as ``roman-sim run`` of it gives), and a closure file (``roman_sim.interop.closures``:
g2o or CSV). Each closure end ``(robot, t)`` is matched to that robot's submap whose centre
time is nearest to ``t``, and the closure's relative body pose becomes an estimate of the
pair's ``T_a_b`` through the run's odometry::

    T_a_b = inv(T_odom_submap_a) @ T_odom_body_a(t_a) @ T_pa_pb @ inv(T_odom_body_b(t_b)) @ T_odom_submap_b

(the body poses at the closure times are the odometry's, interpolated between frames; the
matching runs on the arrays the readers give: ``roman_sim.pipeline.closure_pairs``).
The closures then go through the run's own evaluation as one more method, named
``label`` (``roman_sim.align.closure_table``): the same pairs, truth, correctness,
recall against heading and ambiguity at every operating point, precision, the pose graph
with its closures and the ATE table, the report and the plots, in a new run folder ``out``.
A closure's score is its association count; a closure without one gets the run's
acceptance threshold (``posegraph.lc_association_thresh``), so it counts as accepted.
A pair keeps the first of its closures with the highest score; the others, and closures whose
two ends fall in one submap or on a pair the evaluation does not score (same-robot
neighbours), are listed as unscored (``external.json`` every one, the report the first 20).
With ``trajectories`` (one ``<robot>.tum`` per robot), the system's own trajectories are
scored too (``external_ate.json``, one SE(3)/4-DoF fit over all robots).

Bad input (unknown robot, a time outside the run, a malformed line, a value that is not
finite or out of range, a non-rigid pose, trajectories that do not cover the run) raises
``ConfigError`` naming the file and line before anything is written. ``external.json``
records what was read and matched, and the report starts with a section that marks the
method as an external system.
"""

from __future__ import annotations

import itertools
import json
import logging
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.closure_table import METHOD, TABLE_FORMAT, ClosureTable, TableRow, table_sha256
from roman_sim.core.atomic import atomic_open, output_folder, write_json, write_text
from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.geometry import inv_T
from roman_sim.core.records import from_json, read_json, read_record, to_json_record, write_record
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum
from roman_sim.evaluation.atetable import AteTable, TrajectoryVariant, ate_table
from roman_sim.interop.associate import read_list
from roman_sim.interop.closures import Closure, ClosureSet, read_closures, read_pose_csv
from roman_sim.interop.tum_camera import read_camera_file
from roman_sim.pipeline.closure_pairs import Resolved, Unscored, pose_at, resolve
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
#: The report lists this many unscored closures (``external.json`` lists every one).
REPORT_UNSCORED = 20
#: A closure time may lie this far outside the robot's frames (s).
TIME_TOL_S = 1e-3
#: A trajectory must start and end within this of the robot's first and last frame (s).
COVER_TOL_S = 1.0
_CHUNK = 1 << 14  # unscored closures written at a time


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
    unscored: Mapping[int, str] = field(default_factory=dict)
    trajectories_ate: AteTable | None = None


def _frame_times(source: Path, scenario: Scenario) -> dict[str, NDArray[np.float64]]:
    """Each robot's frame times (seconds since its start): from the run's maps or the export's ``masks.txt``
    (its stamps less the epoch its ``camera.yaml`` names)."""
    if (source / MANIFEST_JSON).is_file():
        maps = _load_stage(source, scenario, MapsStage())
        return {r: m.odometry.t for r, m in maps.maps.items()}
    out = {}
    for r in scenario.robots:
        path = source / r.name / "masks.txt"
        if path.is_file():  # the stamps, checked line by line, in time order, as seconds since the start
            camera = read_camera_file(source / r.name)
            out[r.name] = read_list(path, camera.time_epoch_ns if camera is not None else 0)[0]
    return out


def _robot_order(source: Path, scenario: Scenario) -> list[str]:
    """The robots in the export's order (those it holds), else the scenario's."""
    manifest = source / "export.json"
    if manifest.is_file() and not (source / MANIFEST_JSON).is_file():
        doc = read_json(manifest)  # the export's manifest: only its robots are read
        robots = doc.get("robots") if isinstance(doc, dict) else None
        return list(from_json(dict[str, Any], robots, f"{manifest}: field robots"))  # name -> its summary
    return [r.name for r in scenario.robots]


def _load_stage(run_dir: Path, scenario: Scenario, stage: Any) -> Any:
    man = existing_manifest(run_dir)
    if man is None or stage.name not in man.stages:
        raise StorageError(f"{run_dir}: no {stage.name} stage (is it a finished run folder?)")
    return stage.load(RunContext(scenario, run_dir), man.stages[stage.name].files)


def _check_closures(path: Path, closures: ClosureSet, times: dict[str, NDArray[np.float64]]) -> None:
    """Every closure end's robot is a robot of the run and its time within the robot's frames (ConfigError
    naming the first failing line: a's end before b's, the robot before its time)."""
    allowed = ", ".join(times)
    known = np.asarray([r in times for r in closures.robots], dtype=bool)
    lo = np.asarray([times[r][0] - TIME_TOL_S if r in times else 0.0 for r in closures.robots], dtype=np.float64)
    hi = np.asarray([times[r][-1] + TIME_TOL_S if r in times else 0.0 for r in closures.robots], dtype=np.float64)
    checks = []
    for codes, ts in ((closures.robot_a, closures.t_a), (closures.robot_b, closures.t_b)):
        ok = known[codes]
        checks += [~ok, ok & ~((lo[codes] <= ts) & (ts <= hi[codes]))]
    failed = np.stack(checks, axis=1) if len(closures) else np.zeros((0, 4), dtype=bool)
    if not failed.any():
        return
    row = int(np.flatnonzero(failed.any(axis=1))[0])
    check = int(np.flatnonzero(failed[row])[0])
    code, t_end = (closures.robot_a, closures.t_a) if check < 2 else (closures.robot_b, closures.t_b)
    r, t, line = closures.robots[int(code[row])], float(t_end[row]), int(closures.line[row])
    if check % 2 == 0:
        raise ConfigError(f"{path}:{line}: robot {r!r} is not a robot of the run (allowed: {allowed})")
    frames = times[r]
    raise ConfigError(
        f"{path}:{line}: time {t:.6f} s of robot {r} is outside the run "
        f"(allowed: {frames[0]:.6f} to {frames[-1]:.6f} s)"
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


def _table(res: Resolved, label: str, source: Path) -> ClosureTable:
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


def _report_section(label: str, closures: Path, n: int, res: Resolved, ate: AteTable | None) -> str:
    lines = [
        "## External system",
        "",
        f"Method `{label}` is an external system: its loop closures were read from `{closures}` "
        f"({n} closures; {len(res.pairs)} submap pairs received an estimate, {len(res.unscored)} closures unscored), "
        "matched to this run's submaps by time and scored against the truth like every method.",
    ]
    if res.unscored:
        listed = list(itertools.islice(res.unscored.items(), REPORT_UNSCORED))
        lines += ["", *[f"- line {line}: {why}" for line, why in listed]]
        if len(res.unscored) > len(listed):
            lines.append(f"- and {len(res.unscored) - len(listed)} more (every one in `{EXTERNAL_JSON}`)")
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
    if not is_run and not (src / "export.json").is_file():
        raise ConfigError(f"{src}: neither a run folder (manifest.json) nor an export folder (export.json)")
    output_folder(out, "--out", create=False)  # a file there: one line, not a traceback
    if out.is_dir() and any(out.iterdir()):
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
        write_json(out / EXTERNAL_ATE_JSON, ate.to_json())
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
        unscored={},
    )
    _write_external(out / EXTERNAL_JSON, info, res.unscored)
    report = out / "report.md"
    text = report.read_text(encoding="utf-8")
    head, _, rest = text.partition("\n\n")
    write_text(report, f"{head}\n\n{_report_section(label, path, len(read), res, ate)}{rest}")
    log.info("scored %d closures of %s: %d pairs", len(read), label, len(res.pairs))
    return ExternalScore(run, label, len(read), len(res.pairs), res.unscored, ate)


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


def _write_external(path: Path, info: ExternalRecord, unscored: Mapping[int, str]) -> None:
    """``external.json`` with ``unscored`` filled in, the bytes ``write_record`` gives, its entries
    streamed to the file (a file of millions of unscored closures is never one text in memory)."""
    if not unscored:
        write_record(path, info)
        return
    u = unscored if isinstance(unscored, Unscored) else Unscored.of(unscored)
    mark = "\0unscored\0"
    text = json.dumps(to_json_record(replace(info, unscored={mark: ""})), indent=2, sort_keys=True)
    head, tail = text.split(f'{json.dumps(mark)}: ""')
    reasons = [json.dumps(r) for r in u.reasons]
    order = np.argsort(u.lines.astype(str), kind="stable")  # keys sorted as the strings they are in JSON
    with atomic_open(path, "wb") as fh:
        fh.write(head.encode("ascii"))
        for s in range(0, len(order), _CHUNK):
            rows = order[s : s + _CHUNK]
            entries = ",\n    ".join(
                f'"{line}": {reasons[code]}' for line, code in zip(u.lines[rows].tolist(), u.codes[rows].tolist())
            )
            fh.write((("" if s == 0 else ",\n    ") + entries).encode("ascii"))
        fh.write((tail + "\n").encode("ascii"))


def read_external(run_dir: str | Path) -> ExternalRecord:
    """``external.json`` of a scored folder (RecordError naming the file and field when malformed)."""
    return read_record(Path(run_dir) / EXTERNAL_JSON, ExternalRecord)
