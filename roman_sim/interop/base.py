"""What every sequence writer shares: the writer protocol, time stamps and the registry.

Time stamps are integer nanoseconds ``round(t * 1e9)`` of the frame time ``t`` (seconds
since the robot's start), written in text files as ``<sec>.<nanosec>`` with nine decimals,
so the TUM folder and the ROS 2 bag of one robot carry the same stamps.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from roman_sim.core.jsontypes import JSONLike
from roman_sim.core.registry import Registry
from roman_sim.core.sensors import Frame


def stamp_ns(t: float) -> int:
    """Integer nanoseconds of a time in seconds (>= 0)."""
    return round(float(t) * 1e9)


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
