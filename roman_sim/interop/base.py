"""What every sequence writer shares: the writer protocol, time stamps and the registry.

Time stamps are integer nanoseconds ``round(t * 1e9)`` of the frame time ``t`` (seconds
since the robot's start), written in text files as ``<sec>.<nanosec>`` with nine decimals,
so the TUM folder and the ROS 2 bag of one robot carry the same stamps.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.registry import Registry
from roman_sim.sensors import Frame, Intrinsics


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

    def close(self) -> dict[str, Any]:
        """Finish the files; returns a JSON-friendly summary (counts, paths)."""
        ...

    def abort(self) -> None:
        """Drop what is unfinished after an error (finished files stay)."""
        ...


class WriterFactory(Protocol):
    """Builds a ``SequenceWriter`` for one robot."""

    def __call__(self, out_dir: Path, robot: str, intrinsics: Intrinsics, T_body_cam: NDArray[np.float64],
                 **options: Any) -> SequenceWriter: ...


#: Export formats: name -> writer factory (``tum``, ``rosbag2``).
FORMATS: Registry[Any] = Registry("export format")
