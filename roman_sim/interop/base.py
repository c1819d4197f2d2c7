"""What every sequence writer shares: the writer protocol, time stamps and the registry.

Time stamps are integer nanoseconds from a fixed epoch: ``EXPORT_EPOCH_NS + round(t * 1e9)``
for the frame time ``t`` (seconds since the robot's start), written in text files as
``<sec>.<nanosec>`` with nine decimals, so the TUM folder, the ROS 2 bag and the EuRoC
folder of one robot carry the same stamps. The epoch, 1 700 000 000 s after 1970-01-01
(2023-11-14 22:13:20 UTC), makes them realistic ROS times (tools read a zero stamp as
"unset") while every export stays the same bytes; ``export.json`` records it, and
``frame_time`` takes a stamp back to seconds since the start.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, Protocol

from roman_sim.core.jsontypes import JSONLike, JSONScalar
from roman_sim.core.records import INLINE, OMIT_NONE, read_record
from roman_sim.core.registry import Registry
from roman_sim.core.sensors import Frame

#: The epoch of exported stamps (ns since 1970-01-01 UTC): 2023-11-14 22:13:20 UTC.
EXPORT_EPOCH_NS = 1_700_000_000 * 1_000_000_000
#: An export folder's manifest.
EXPORT_JSON = "export.json"
EXPORT_FORMAT: Literal["roman_sim.export"] = "roman_sim.export"


@dataclass(frozen=True)
class ExportConventions:
    """How an export's stamps, frames and masks are to be read (stated in ``export.json``)."""

    time: str = "stamp = time_epoch_ns + seconds since the robot's start, in integer nanoseconds"
    world: str = "frame of groundtruth.txt, objects.json and the 'world' tf frame"
    masks: str = "16-bit PNG, object id + 1 (0 = background)"


@dataclass(frozen=True)
class RobotCounts:
    """What a sequence writer wrote for one robot: its frames, the format's own counts (depth
    values dropped, cameras, IMU samples) and, for a ROS 2 bag, its messages per topic."""

    frames: int
    counts: dict[str, int] = field(default_factory=dict, metadata=INLINE)
    messages: dict[str, int] | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class RobotExport:
    """One robot's export: where it was written (its folder, or its bag) and what (``export.json``
    keeps the counts, not the path)."""

    path: str
    written: RobotCounts

    @classmethod
    def of(cls, summary: Mapping[str, JSONLike]) -> RobotExport:
        """The export of a writer's summary (``SequenceWriter.close``: ``frames``, ``folder`` or
        ``bag``, ``messages`` per topic and counts of its own)."""
        where = summary.get("bag") or summary.get("folder")
        messages = summary.get("messages")
        own = {k: v for k, v in summary.items() if k not in ("frames", "folder", "bag", "messages")}
        counts = {k: int(v) for k, v in own.items() if isinstance(v, (int, float))}
        topics = None
        if isinstance(messages, Mapping):
            topics = {str(k): v for k, v in messages.items() if isinstance(v, int)}
        frames = summary["frames"]
        return cls(str(where), RobotCounts(int(frames) if isinstance(frames, (int, float)) else 0, counts, topics))


@dataclass(frozen=True)
class ExportManifest:
    """What ``export.json`` holds: the export's format, epoch, scenario, writer options, each robot's
    writer summary (its own counts, as the format's writer gives them) and the conventions."""

    format: Literal["roman_sim.export"]
    version: int
    sequence_format: str
    scenario: str
    seed: int
    options: dict[str, JSONScalar]
    robots: dict[str, RobotCounts]
    time_epoch_ns: int = 0  # an export written before the epoch was stamped from 0
    conventions: ExportConventions = ExportConventions()


def read_export_manifest(folder: str | Path) -> ExportManifest:
    """The ``export.json`` of an export folder (RecordError naming the file and the field)."""
    return read_record(Path(folder) / EXPORT_JSON, ExportManifest)


def stamp_ns(t: float) -> int:
    """Integer nanoseconds of the exported stamp of a time ``t`` in seconds since the start (>= 0)."""
    return EXPORT_EPOCH_NS + round(float(t) * 1e9)


def frame_time(ns: int) -> float:
    """Seconds since the start of an exported stamp (``stamp_ns``'s inverse, to the nanosecond)."""
    return (int(ns) - EXPORT_EPOCH_NS) / 1e9


def stamp_text(ns: int) -> str:
    """``<sec>.<nanosec>`` with nine decimals (sorts like the time, parses as the float)."""
    return f"{ns // 1_000_000_000}.{ns % 1_000_000_000:09d}"


class SequenceWriter(Protocol):
    """Writes one robot's frames, one at a time, into its own folder."""

    def write(self, frame: Frame) -> None:
        """Store one frame (with truth: instance ids and true body pose)."""
        ...

    def close(self) -> dict[str, JSONLike]:
        """Finish the files; returns a JSON-friendly summary (counts, paths)."""
        ...

    def abort(self) -> None:
        """Drop what is unfinished after an error (finished files stay)."""
        ...


#: Export formats: name -> ``SequenceWriter`` class, called as
#: ``cls(out_dir, robot, intrinsics, T_body_cam, **options)`` (``tum``, ``rosbag2``, or a
#: user's ``package.module:Class``).
FORMATS: Registry[Callable[..., SequenceWriter]] = Registry("export format")
