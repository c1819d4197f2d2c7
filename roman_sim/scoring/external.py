"""Score any system's loop closures (and trajectories) against a run's truth, as a run of its own.

``score_external(source, closures, out)`` takes a finished run folder, or an export folder
(its ``config.yaml`` is the scenario: the run's maps and submaps are computed first, the
same as ``roman-sim run`` of it gives), and a closure file in any format
``roman_sim.interop.closure_files`` reads (CSV, g2o, the reference ROMAN's per-pair output,
Kimera-Multi's ``loop_closures.csv``). Each file's stamps are taken on their clock (since the
start, or the export's: ``roman_sim.interop.stamps``) and must match a frame of their robot
within ``MATCH_TOL_S``; the file is read with the convention the flags give and scored under
every other (``roman_sim.scoring.closure_conventions``): a far better one is named in one
line, a flag that makes it worse is an error. Each closure end ``(robot, t)`` is matched to
that robot's submap whose centre time is nearest to ``t``, and the closure's relative body
pose becomes an estimate of the pair's ``T_a_b`` through the run's odometry::

    T_a_b = inv(T_odom_submap_a) @ T_odom_body_a(t_a) @ T_pa_pb @ inv(T_odom_body_b(t_b)) @ T_odom_submap_b

(the body poses at the closure times are the odometry's, interpolated between frames; the
matching runs on the arrays the readers give: ``roman_sim.scoring.closure_pairs``).
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

Bad input (a file in an unknown format, an unknown robot, a stamp that matches no frame, a
malformed line, a value that is not finite or out of range, a non-rigid pose, a convention
flag that makes the file score worse, trajectories that do not cover the run or match no
frame) raises ``ConfigError`` naming the file and line before anything is written (an
export's maps, computed into ``out`` first, are removed again). ``external.json``
records what was read and matched, and the report starts with a section that marks the
method as an external system.
"""

from __future__ import annotations

import csv
import gzip
import io
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
from roman_sim.core.atomic import atomic_open, output_folder, write_text
from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.geometry import inv_T
from roman_sim.core.records import read_record, to_json_record, write_record
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum
from roman_sim.evaluation.atetable import ATE_SCHEMA, AteTable, TrajectoryVariant, ate_table
from roman_sim.interop.associate import read_list
from roman_sim.interop.base import EXPORT_EPOCH_NS, EXPORT_JSON, read_export_manifest
from roman_sim.interop.closure_files import read_closure_file
from roman_sim.interop.closures import QUATERNION_ORDERS, Closure, ClosureSet, QuaternionOrder, read_pose_csv
from roman_sim.interop.roman_align import write_align
from roman_sim.interop.stamps import MATCH_TOL_S, Clock, file_clock, matched, no_frame, since_start_s
from roman_sim.pipeline.context import Progress, RunContext
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.manifest import MANIFEST_JSON, Manifest, StageRecord, existing_manifest
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import Scenario, load_scenario
from roman_sim.pipeline.stages.maps import MapsStage
from roman_sim.pipeline.stages.submaps import SubmapsStage
from roman_sim.scoring.closure_conventions import Convention, ConventionCheck, apply, check, on_frames, swapped
from roman_sim.scoring.closure_pairs import Resolved, Unscored, pose_at, resolve

log = logging.getLogger(__name__)

TABLE_JSON = "external_closures.json"
EXTERNAL_JSON = "external.json"
EXTERNAL_ATE_JSON = "external_ate.json"
#: The report lists this many unscored closures (``external.json`` lists every one).
REPORT_UNSCORED = 20
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
        conventions: the closures' correct pairs under every convention tried.
        warning: one line when another convention scores far better (None otherwise).
    """

    run: RunResult
    label: str
    n_closures: int
    n_pairs: int
    unscored: Mapping[int, str] = field(default_factory=dict)
    trajectories_ate: AteTable | None = None
    conventions: ConventionCheck | None = None
    warning: str | None = None


def _export_epoch(source: Path) -> int:
    """The epoch of the stamps a system run on ``source`` gives (ns since 1970): an export's ``time_epoch_ns``
    (0 for an export without one, stamped from 0), for a run folder the one every export is stamped from."""
    if not (source / EXPORT_JSON).is_file() or (source / MANIFEST_JSON).is_file():
        return EXPORT_EPOCH_NS
    return read_export_manifest(source).time_epoch_ns


def _frame_times(source: Path, scenario: Scenario) -> dict[str, NDArray[np.float64]]:
    """Each robot's frame times (seconds since its start): from the run's maps or the export's ``masks.txt``
    (its stamps less the export's epoch)."""
    if (source / MANIFEST_JSON).is_file():
        maps = _load_stage(source, scenario, MapsStage())
        return {r: m.odometry.t for r, m in maps.maps.items()}
    out, epoch = {}, _export_epoch(source)
    for r in scenario.robots:
        path = source / r.name / "masks.txt"
        if path.is_file():  # the stamps, checked line by line, in time order, as seconds since the start
            out[r.name] = read_list(path, epoch)[0]
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


def _where(path: Path, cs: ClosureSet, line: int) -> str:
    """``file:line`` of a line of ``cs`` (a set read from a folder names the file in it)."""
    name, n = cs.locate(line)
    return f"{path if name is None else path / name}:{n}"


def _clock_of(cs: ClosureSet, clocks: Sequence[Clock], line: int) -> Clock:
    """The clock of the file a line of ``cs`` was read from."""
    k = sum(1 for _, before in cs.files[1:] if before < line)
    return clocks[k] if clocks else Clock()


def _to_run_clock(
    path: Path, cs: ClosureSet, epoch_ns: int, frames: dict[str, NDArray[np.float64]]
) -> tuple[ClosureSet, list[Clock]]:
    """The closures' stamps as seconds since the start, each file on its clock (``roman_sim.interop.stamps``)."""
    every = np.unique(np.concatenate(list(frames.values()))) if frames else None
    starts = [before for _, before in cs.files] or [0]
    t_a, t_b, clocks = cs.t_a.copy(), cs.t_b.copy(), []
    for k, before in enumerate(starts):
        rows = (cs.line > before) & (cs.line <= (starts[k + 1] if k + 1 < len(starts) else np.inf))
        where = path / cs.files[k][0] if cs.files else path
        lines = cs.line[rows] - before
        clock = file_clock(where, np.concatenate([cs.t_a[rows], cs.t_b[rows]]), np.tile(lines, 2), epoch_ns, every)
        t_a[rows], t_b[rows] = since_start_s(cs.t_a[rows], clock), since_start_s(cs.t_b[rows], clock)
        clocks.append(clock)
    return replace(cs, t_a=t_a, t_b=t_b), clocks


def _check_closures(
    path: Path,
    closures: ClosureSet,
    times: dict[str, NDArray[np.float64]],
    clocks: Sequence[Clock] = (),
    swap_given: bool = False,
) -> None:
    """Every closure end's robot is a robot of the run and its time matches one of the robot's frames within
    ``MATCH_TOL_S`` (ConfigError naming the first failing line: a's end before b's, the robot before its time)."""
    cs, allowed = closures, ", ".join(times)
    checks = []
    for codes, ts in ((cs.robot_a, cs.t_a), (cs.robot_b, cs.t_b)):
        known, on = np.zeros(len(cs), dtype=bool), np.zeros(len(cs), dtype=bool)
        for k, r in enumerate(cs.robots):
            mine = codes == k
            if r in times and mine.any():
                known[mine], on[mine] = True, matched(times[r], ts[mine])
        checks += [~known, known & ~on]
    failed = np.stack(checks, axis=1) if len(cs) else np.zeros((0, 4), dtype=bool)
    if not failed.any():
        return
    row = int(np.flatnonzero(failed.any(axis=1))[0])
    kind = int(np.flatnonzero(failed[row])[0])
    code, t_end = (cs.robot_a, cs.t_a) if kind < 2 else (cs.robot_b, cs.t_b)
    r, t, line = cs.robots[int(code[row])], float(t_end[row]), int(cs.line[row])
    if kind % 2 == 0:
        raise ConfigError(f"{_where(path, cs, line)}: robot {r!r} is not a robot of the run (allowed: {allowed})")
    clock = _clock_of(cs, clocks, line)
    hint = ""
    if len(times) == 2 and on_frames(swapped(cs, list(times)), times).all():
        hint = f"; {'without' if swap_given else 'with'} --swap-robots every closure matches a frame"
    raise ConfigError(f"{_where(path, cs, line)}: {no_frame(t + clock.epoch_ns / 1e9, clock, r, times[r])}{hint}")


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


def _data_lines(path: Path) -> NDArray[np.int64]:
    """The line of each pose of a trajectory file (TUM, or the reference's CSV after its header), in order."""
    raw = path.read_bytes()
    text = (gzip.decompress(raw) if path.suffix == ".gz" else raw).decode("utf-8")
    if path.suffix == ".csv":
        lines = [n for n, row in enumerate(csv.reader(io.StringIO(text)), start=1) if n > 1 and row]
    else:
        lines = [n for n, ln in enumerate(text.splitlines(), start=1) if ln.strip() and not ln.strip().startswith("#")]
    return np.asarray(lines, dtype=np.int64)


def _check_poses(
    path: Path, tr: Trajectory, lines: NDArray[np.int64], clock: Clock, robot: str, frames: NDArray[np.float64]
) -> None:
    """A trajectory's stamps against the robot's frames (ConfigError naming the first that fails): with no more
    poses than frames (keyframes, frames) every stamp matches a frame; a denser one (e.g. at an IMU's rate)
    has a pose within ``MATCH_TOL_S`` of every frame it spans."""
    if len(tr) <= len(frames):
        ok = matched(frames, tr.t)
        if not ok.all():
            i = int(np.flatnonzero(~ok)[0])
            raise ConfigError(
                f"{path}:{int(lines[i])}: {no_frame(float(tr.t[i]) + clock.epoch_ns / 1e9, clock, robot, frames)}"
            )
        return
    spanned = frames[(frames >= tr.t[0] - MATCH_TOL_S) & (frames <= tr.t[-1] + MATCH_TOL_S)]
    ok = matched(tr.t, spanned)
    if not ok.all():
        f = float(spanned[int(np.flatnonzero(~ok)[0])])
        raise ConfigError(
            f"{path}: no pose within {MATCH_TOL_S:g} s of robot {robot}'s frame at {f:.6f} s (a trajectory with more "
            f"poses than the robot has frames needs one at every frame it spans; the file's clock: {clock.describe()})"
        )


def _read_trajectories(
    folder: Path, times: dict[str, NDArray[np.float64]], epoch_ns: int = EXPORT_EPOCH_NS
) -> tuple[dict[str, Trajectory], dict[str, Clock]]:
    """Every robot's trajectory (``_read_trajectory``) on the run's clock, each covering the robot's frames and
    matching them (``_check_poses``; ConfigError otherwise), and each file's clock."""
    if not folder.is_dir():
        raise ConfigError(f"--trajectories {folder}: not a folder")
    out, clocks = {}, {}
    every = np.unique(np.concatenate(list(times.values()))) if times else None
    for r, ts in times.items():
        path, read = _read_trajectory(folder, r, list(times))
        lines = _data_lines(path)
        clock = file_clock(path, read.t, lines, epoch_ns, every)
        tr = Trajectory(since_start_s(read.t, clock), read.T) if clock.epoch_ns else read
        if len(tr) < 3 or tr.t[0] > ts[0] + COVER_TOL_S or tr.t[-1] < ts[-1] - COVER_TOL_S:
            span_text = f"{tr.t[0]:.3f} to {tr.t[-1]:.3f} s" if len(tr) else "no poses"
            raise ConfigError(
                f"{path}: covers {span_text}; robot {r} runs {ts[0]:.3f} to {ts[-1]:.3f} s (allowed: from at most "
                f"{COVER_TOL_S:g} s after its first frame to at most {COVER_TOL_S:g} s before its last, "
                "3 poses or more)"
            )
        _check_poses(path, tr, lines, clock, r, ts)
        out[r], clocks[path.name] = tr, clock
    return out, clocks


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


@dataclass
class _Input:
    """The closures as ``score_external`` reads them.

    Attributes:
        closures: on the run's clock, in the chosen convention.
        on_clock: on the run's clock, with the chosen quaternion order only (what the check turns).
        fmt: the file's format (``roman_sim.interop.closure_files``).
        clocks: each file's clock.
        convention: the chosen convention.
        given: the convention flags the user gave.
    """

    closures: ClosureSet
    on_clock: ClosureSet
    fmt: str
    clocks: list[Clock]
    convention: Convention
    given: list[str]


def _read_input(
    path: Path,
    times: str | Path | None,
    order: list[str],
    frames: dict[str, NDArray[np.float64]],
    epoch_ns: int,
    flags: tuple[QuaternionOrder | None, bool, bool],
) -> _Input:
    """Read the closure file with the convention ``flags`` (quaternion order or None, invert, swap), on the run's
    clock, every end checked against the frames (ConfigError otherwise)."""
    order_q, invert, swap = flags
    if order_q is not None and order_q not in QUATERNION_ORDERS:
        raise ConfigError(f"--quaternion-order {order_q}: allowed: {', '.join(QUATERNION_ORDERS)}")
    if swap and len(frames) != 2:
        raise ConfigError(f"--swap-robots: the run has {len(frames)} robots (allowed: a run of two robots)")
    conv = Convention(order_q or "xyzw", invert, swap)
    given = ["--quaternion-order"] * (order_q is not None) + ["--invert-edges"] * invert + ["--swap-robots"] * swap
    raw, fmt = read_closure_file(path, order, times, conv.quaternion_order)
    on_clock, clocks = _to_run_clock(path, raw, epoch_ns, frames)
    read = apply(on_clock, conv, list(frames))
    _check_closures(path, read, frames, clocks, swap)
    return _Input(read, on_clock, fmt, clocks, conv, given)


def _check_conventions(
    path: Path, got: _Input, frames: dict[str, NDArray[np.float64]], maps: Any, subs: Any, scenario: Scenario
) -> tuple[ConventionCheck, str | None]:
    """The closures scored under every convention; ConfigError when a flag given makes them score far worse,
    else the warning line when another convention scores far better."""
    odom = {r: m.odometry for r, m in maps.maps.items()}
    checked = check(got.on_clock, got.convention, frames, subs.submaps, odom, scenario)
    error, warning = checked.verdict(path, got.given)
    if error is not None:
        raise ConfigError(error)
    if warning is not None:
        log.info("%s", warning)
    return checked, warning


def _clear(out: Path, fresh: bool) -> None:
    """Remove what scoring wrote into ``out`` (the folder too when it did not exist before)."""
    if fresh:
        shutil.rmtree(out, ignore_errors=True)
        return
    for child in out.iterdir() if out.is_dir() else []:
        shutil.rmtree(child, ignore_errors=True) if child.is_dir() else child.unlink(missing_ok=True)


def _report_section(
    label: str, closures: Path, got: _Input, res: Resolved, ate: AteTable | None, warning: str | None
) -> str:
    n = len(got.closures)
    lines = [
        "## External system",
        "",
        f"Method `{label}` is an external system: its loop closures were read from `{closures}` "
        f"({n} closures; {len(res.pairs)} submap pairs received an estimate, {len(res.unscored)} closures unscored), "
        "matched to this run's submaps by time and scored against the truth like every method. "
        f"Format `{got.fmt}`, convention {got.convention.describe()}, stamps on "
        f"{'; '.join(sorted({c.describe() for c in got.clocks})) or Clock().describe()}.",
    ]
    if warning is not None:
        lines += ["", f"**Warning:** {warning}"]
    if res.unscored:
        listed = list(itertools.islice(res.unscored.items(), REPORT_UNSCORED))
        where = [f"line {line}" if not got.closures.files else _where(Path(), got.closures, line) for line, _ in listed]
        lines += ["", *[f"- {at}: {why}" for at, (_, why) in zip(where, listed)]]
        if len(res.unscored) > len(listed):
            lines.append(f"- and {len(res.unscored) - len(listed)} more (every one in `{EXTERNAL_JSON}`)")
    if ate is not None:
        lines += ["", "Its own trajectories, ATE RMSE (m), one SE(3) fit over all robots:", ""]
        for name, row in ate.variants.items():
            cells = ", ".join(f"{k} {v:.3f}" for k, v in row.rmse["se3"].items() if v is not None)
            lines.append(f"- {name}: {cells}")
    return "\n".join(lines) + "\n\n"


def _maps_and_submaps(
    src: Path, out: Path, scenario: Scenario, label: str, path: Path, progress: Progress | None
) -> tuple[Any, Any]:
    """The run's maps and submaps: a run folder's own, or an export's scenario run into ``out`` for them."""
    if (src / MANIFEST_JSON).is_file():
        return _load_stage(src, scenario, MapsStage()), _load_stage(src, scenario, SubmapsStage())
    out.mkdir(parents=True, exist_ok=True)
    table = (out / TABLE_JSON).resolve()
    write_record(table, ClosureTable(TABLE_FORMAT, 1, label, str(path), []))
    Experiment(_external_scenario(scenario, label, table, table_sha256(table)), out, progress=progress).run()
    return _load_stage(out, scenario, MapsStage()), _load_stage(out, scenario, SubmapsStage())


def score_external(
    source: str | Path,
    closures: str | Path,
    out_dir: str | Path,
    *,
    times: str | Path | None = None,
    robots: Sequence[str] | None = None,
    trajectories: str | Path | None = None,
    label: str = "external",
    quaternion_order: QuaternionOrder | None = None,
    invert_edges: bool = False,
    swap_robots: bool = False,
    progress: Progress | None = None,
) -> ExternalScore:
    """Score an external system's loop closures (and trajectories) on ``source``'s scenario into ``out_dir``.

    Args:
        source: a finished run folder (``manifest.json``) or an export folder (``export.json``).
        closures: a closure file or folder in any format ``roman_sim.interop.closure_files`` reads.
        out_dir: the new run folder (must not hold files).
        times: a g2o file's timestamps file (the reference's dense one for its per-pair files,
            Kimera-Multi's ``odometry_poses.csv`` file or folder).
        robots: robot order of a g2o file's keys, the reference's ``runs``, Kimera-Multi's robot
            indices (default: the scenario's robots).
        trajectories: folder of ``<robot>.tum`` trajectories of the system.
        label: the method's name in tables.
        quaternion_order: the order of the file's quaternion numbers (None: ``xyzw``, not stated).
        invert_edges: the file's relative poses are ``T_b_a``.
        swap_robots: the file's two robots are exchanged.
        progress: progress sink.
    """
    src, out, path = Path(source), Path(out_dir), Path(closures)
    is_run = (src / MANIFEST_JSON).is_file()
    if not is_run and not (src / EXPORT_JSON).is_file():
        raise ConfigError(f"{src}: neither a run folder (manifest.json) nor an export folder (export.json)")
    output_folder(out, "--out", create=False)  # a file there: one line, not a traceback
    if out.is_dir() and any(out.iterdir()):
        raise ConfigError(f"--out {out}: already holds files (choose a new folder)")
    if not label or "/" in label or ":" in label:
        raise ConfigError(f"--label {label!r}: a non-empty name without '/' or ':'")
    scenario = load_scenario(src / "config.yaml")
    order = list(robots) if robots else _robot_order(src, scenario)
    frame_t, epoch = _frame_times(src, scenario), _export_epoch(src)
    got = _read_input(path, times, order, frame_t, epoch, (quaternion_order, invert_edges, swap_robots))
    own, own_clocks = _read_trajectories(Path(trajectories), frame_t, epoch) if trajectories is not None else (None, {})
    fresh = not out.exists()
    try:
        maps, subs = _maps_and_submaps(src, out, scenario, label, path, progress)
        checked, warning = _check_conventions(path, got, frame_t, maps, subs, scenario)
    except ConfigError:
        if not is_run:
            _clear(out, fresh)
        raise
    out.mkdir(parents=True, exist_ok=True)
    if is_run:
        _seed_from_run(src, out)
    table = (out / TABLE_JSON).resolve()
    res = resolve(got.closures, subs.submaps, {r: m.odometry for r, m in maps.maps.items()}, scenario)
    write_record(table, _table(res, label, path))
    sc = _external_scenario(scenario, label, table, table_sha256(table))
    run = Experiment(sc, out, progress=progress).run()
    ate = None
    if own is not None:
        truth = {r: m.truth for r, m in maps.maps.items() if m.truth is not None}
        name = f"{label}_trajectories"
        ate = ate_table(truth, {name: TrajectoryVariant(f"{label}'s own trajectories", "joint", name)}, {name: own})
        write_record(out / EXTERNAL_ATE_JSON, ate.record(), ATE_SCHEMA)
    clocks = {name or str(path): c.describe() for (name, _), c in zip(got.closures.files or [("", 0)], got.clocks)}
    info = ExternalRecord(
        format="roman_sim.external_score",
        version=1,
        label=label,
        source=str(src),
        closures=str(path),
        times=None if times is None else str(times),
        robots=order,
        trajectories=None if trajectories is None else str(trajectories),
        n_closures=len(got.closures),
        n_pairs=len(res.pairs),
        unscored={},
        closure_format=got.fmt,
        convention=got.convention.describe(),
        clocks={**clocks, **{k: c.describe() for k, c in own_clocks.items()}},
        correct_by_convention={c.describe(): n for c, n in checked.correct.items()},
        warning=warning,
    )
    _write_external(out / EXTERNAL_JSON, info, res.unscored)
    report = out / "report.md"
    text = report.read_text(encoding="utf-8")
    head, _, rest = text.partition("\n\n")
    write_text(report, f"{head}\n\n{_report_section(label, path, got, res, ate, warning)}{rest}")
    log.info("scored %d closures of %s: %d pairs", len(got.closures), label, len(res.pairs))
    return ExternalScore(run, label, len(got.closures), len(res.pairs), res.unscored, ate, checked, warning)


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


def write_reference_align(
    run_dir: str | Path, out: str | Path, method: str = "roman", min_score: int | None = None
) -> list[Path]:
    """A run's own closures of ``method`` (``run_closures``) written in the reference ROMAN's per-pair layout
    (``roman_sim.interop.roman_align.write_align``: ``out/align/<r_i>_<r_j>/align.g2o`` and ``align.json``, the
    dense timestamps files), stamped on the export's clock as the reference stamps them when it runs on the
    ROMAN-ready export; closures below ``min_score`` associations are left out (the demo's ``-n``)."""
    src = Path(run_dir)
    scenario = load_scenario(src / "config.yaml")
    maps = _load_stage(src, scenario, MapsStage())
    frames = {r: m.odometry.t for r, m in maps.maps.items()}
    robots = [r.name for r in scenario.robots]
    return write_align(out, run_closures(src, method), frames, robots, EXPORT_EPOCH_NS, min_score)


@dataclass(frozen=True)
class ExternalRecord:
    """``external.json``: what was scored (the source folder, the closures and their times, the robot
    order, the system's own trajectories), the closures read, the pairs estimated and why the others
    were not scored (by line of the closures file), the file's format, the convention it was read
    with, each file's clock, the correct pairs under every convention tried and the warning, if any."""

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
    closure_format: str = "csv"
    convention: str = "as read"
    clocks: dict[str, str] = field(default_factory=dict)
    correct_by_convention: dict[str, int] = field(default_factory=dict)
    warning: str | None = None


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
