"""Export a scenario's robots as standard sequences (TUM RGB-D folders or ROS 2 bags).

Output folder::

    config.yaml      the resolved scenario (seed included: re-export gives the same bytes)
    objects.json     object table (ids, families, oriented boxes; world frame), and
    objects.csv      the same as a flat table
    export.json      format, robots, frame counts, conventions
    <robot>/         one sequence per robot (``roman_sim.interop.tum_writer``,
                     ``rosbag_writer``, ``roman_export`` or ``euroc``), with instance masks
                     in masks/

Frames are rendered and written one at a time (never more than one frame in memory),
every file is written atomically, and the same scenario and seed give the same bytes. A
writer with a ``set_rig`` method also gets each robot's ``SensorRig`` (continuous truth,
IMU readings, second camera) before its first frame; a robot with an IMU or a second camera
exported in a format without one (``tum``) is warned about. So is a camera whose pixels are
not square (fx != fy, only with an explicit ``camera.vfov_deg``): real cameras' are, and some
systems assume it.
"""

from __future__ import annotations

import logging
import shutil
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from roman_sim.core.atomic import output_folder, write_text
from roman_sim.core.config import dump_yaml
from roman_sim.core.errors import ConfigError
from roman_sim.core.jsontypes import JSONScalar
from roman_sim.core.records import write_record
from roman_sim.core.sensors import FrameSource
from roman_sim.interop import euroc as _euroc  # noqa: F401  (registers "euroc")
from roman_sim.interop import roman_export as _roman  # noqa: F401  (registers "roman")
from roman_sim.interop import rosbag_writer as _rosbag  # noqa: F401  (registers "rosbag2")
from roman_sim.interop import tum_writer as _tum  # noqa: F401  (registers "tum")
from roman_sim.interop.base import EXPORT_EPOCH_NS, EXPORT_FORMAT, EXPORT_JSON, FORMATS, ExportManifest, RobotExport
from roman_sim.interop.looks import table_looks
from roman_sim.interop.objects import write_object_table
from roman_sim.interop.source import scenario_streams, select_robots

log = logging.getLogger(__name__)


class ExportProgress(Protocol):
    """Progress sink (the CLI draws bars); stage names are ``export:<robot>``."""

    def start(self, stage: str, total: int | None = None) -> None: ...

    def advance(self, stage: str, n: int = 1) -> None: ...

    def end(self, stage: str) -> None: ...


@dataclass
class ExportResult:
    """What an export wrote, and where the time went (timings are not written to disk).

    Attributes:
        out_dir: the export folder.
        format: ``tum`` or ``rosbag2``.
        robots: per robot, the writer's summary (frame and message counts, paths).
        render_s: per robot, seconds spent rendering frames.
        write_s: per robot, seconds spent encoding and writing them.
    """

    out_dir: Path
    format: str
    robots: dict[str, RobotExport] = field(default_factory=dict)
    render_s: dict[str, float] = field(default_factory=dict)
    write_s: dict[str, float] = field(default_factory=dict)


def _prepare(out: Path, names: list[str], overwrite: bool) -> None:
    output_folder(out, "--out", create=False)
    for name in names:
        d = out / name
        if d.exists() and not d.is_dir():
            raise ConfigError(f"--out {out}: {d} is an existing file, not a robot folder")
        if d.exists() and any(d.iterdir()):
            if not overwrite:
                raise ConfigError(f"--out {out}: {d} already holds files (pass --overwrite to replace them)")
            shutil.rmtree(d)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ConfigError(f"--out {out}: cannot create it ({err.strerror or err})") from None


def _add_sensors(writer: Any, stream: FrameSource, fmt: str) -> None:
    """Give the writer the robot's sensor rig (when both have one); warn about what the format drops."""
    k = stream.intrinsics
    if k.fx != k.fy:
        log.warning(
            "robot %s: the camera's pixels are not square (fx %.3f, fy %.3f); leave camera.vfov_deg unset "
            "(null) for square pixels",
            stream.name,
            k.fx,
            k.fy,
        )
    rig_of = getattr(stream, "rig", None)
    if rig_of is None:
        return
    rig = rig_of()
    set_rig = getattr(writer, "set_rig", None)
    if set_rig is not None:
        set_rig(rig)
    elif rig.imu is not None or rig.T_cam_cam2 is not None:
        log.warning("robot %s: the %s format has no IMU or second camera; they are not exported", stream.name, fmt)


def _export_robot(
    stream: FrameSource,
    fmt: str,
    out: Path,
    options: dict[str, JSONScalar],
    progress: ExportProgress | None,
    result: ExportResult,
) -> None:
    stage = f"export:{stream.name}"
    try:
        writer = FORMATS.get(fmt)(out / stream.name, stream.name, stream.intrinsics, stream.T_body_cam, **options)
    except TypeError as err:
        raise ConfigError(f"export format {fmt!r}: bad option ({err})") from None
    try:
        _add_sensors(writer, stream, fmt)
    except BaseException:
        writer.abort()
        raise
    if progress:
        progress.start(stage, len(stream))
    render_s = write_s = 0.0
    frames = stream.frames()
    try:
        while True:
            t0 = time.perf_counter()
            frame = next(frames, None)
            t1 = time.perf_counter()
            render_s += t1 - t0
            if frame is None:
                break
            writer.write(frame)
            write_s += time.perf_counter() - t1
            if progress:
                progress.advance(stage)
        t1 = time.perf_counter()
        result.robots[stream.name] = RobotExport.of(writer.close())
        write_s += time.perf_counter() - t1
    except BaseException:
        writer.abort()
        raise
    finally:
        close = getattr(frames, "close", None)
        if close is not None:
            close()  # releases the renderer's GL context when the loop stopped early
    if progress:
        progress.end(stage)
    result.render_s[stream.name], result.write_s[stream.name] = render_s, write_s


def export_scenario(
    scenario: Any,
    fmt: str,
    out_dir: str | Path,
    robots: Sequence[str] | None = None,
    progress: ExportProgress | None = None,
    overwrite: bool = False,
    **options: JSONScalar,
) -> ExportResult:
    """Render every selected robot of ``scenario`` and write it in format ``fmt``.

    Args:
        scenario: a validated ``Scenario``.
        fmt: ``tum``, ``rosbag2``, ``roman`` or ``euroc`` (``FORMATS``).
        out_dir: export folder (created).
        robots: robot names to export (all when None).
        progress: progress sink.
        overwrite: replace robots' folders that already hold files (else ConfigError).
        options: writer options (``depth_scale`` for tum; ``storage``, ``distro`` for rosbag2).
    """
    FORMATS.get(fmt)  # an unknown format fails before any rendering
    out = Path(out_dir)
    _prepare(out, [r.name for r in select_robots(scenario, robots)], overwrite)
    world, streams = scenario_streams(scenario, robots)
    write_text(out / "config.yaml", dump_yaml(scenario))
    looks = table_looks(world, [(r.name, r.lighting) for r in scenario.robots], int(scenario.seed))
    write_object_table(out, world.truth, scenario.name, int(scenario.seed), looks)
    result = ExportResult(out, fmt)
    for stream in streams:
        _export_robot(stream, fmt, out, options, progress, result)
        log.info("robot %s: %d frames exported as %s", stream.name, len(stream), fmt)
    finish = getattr(FORMATS.get(fmt), "finish_export", None)
    if finish is not None:  # files of the whole export (e.g. the ROMAN parameter folders)
        finish(out, scenario, streams, result.robots)
    summaries = {name: r.written for name, r in result.robots.items()}
    what = (EXPORT_FORMAT, 1, fmt, scenario.name, int(scenario.seed), options, summaries)
    write_record(out / EXPORT_JSON, ExportManifest(*what, time_epoch_ns=EXPORT_EPOCH_NS))
    return result
