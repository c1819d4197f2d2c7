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

from collections.abc import Callable
from typing import Protocol

from roman_sim.core.jsontypes import JSONLike
from roman_sim.core.registry import Registry
from roman_sim.core.sensors import Frame

#: The epoch of exported stamps (ns since 1970-01-01 UTC): 2023-11-14 22:13:20 UTC.
EXPORT_EPOCH_NS = 1_700_000_000 * 1_000_000_000


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
