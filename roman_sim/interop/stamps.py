"""The clock of a file's stamps, and stamps matched to a robot's frames.

A system run on an exported sequence stamps its output with the export's stamps: the
export's epoch (``time_epoch_ns``, ``roman_sim.interop.base.EXPORT_EPOCH_NS``) plus the time
since the robot's start. A file of closures, keyframe times or poses is read on either
clock, decided per file by its stamps' magnitude: every stamp at least ``EPOCH_MIN_S``
seconds (1e9 s after 1970 is 2001-09-09, and no drive lasts 30 years) is on the export's
clock and the epoch is taken off; every stamp below it counts from the robot's start; a
file that mixes the two is an error naming the first stamp on the other clock.

A stamp then matches a frame of its robot when it lies within ``MATCH_TOL_S`` of one (the
ATE's association tolerance); ``no_frame`` says why one does not, with what it looks like:
nanoseconds (the stamp divided by 1e9 falls within the robot's frames) or a clock offset
(the nearest frame and how far it is).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError
from roman_sim.core.trajectory import MAX_DIFF_S

#: A file whose stamps are all at least this many seconds is on the export's clock (s since 1970).
EPOCH_MIN_S = 1e9
#: A stamp matches a frame of its robot within this (s): the ATE's association tolerance.
MATCH_TOL_S = MAX_DIFF_S


@dataclass(frozen=True)
class Clock:
    """The clock of one file's stamps.

    Attributes:
        epoch_ns: the epoch taken off its stamps (ns since 1970; 0: they count from the start).
    """

    epoch_ns: int = 0

    def describe(self) -> str:
        """The clock in words (for ``external.json`` and messages)."""
        if not self.epoch_ns:
            return "seconds since the robot's start"
        return f"the export's clock (epoch {self.epoch_ns} ns taken off)"


def file_clock(
    path: str | Path,
    t_s: NDArray[np.float64],
    lines: NDArray[np.int64],
    epoch_ns: int,
    frames: NDArray[np.float64] | None = None,
) -> Clock:
    """The clock of a file's stamps ``t_s`` (s, as read; ``lines``: each one's line), by their magnitude.

    Args:
        path: the file (named in errors).
        t_s: its stamps in seconds, as read.
        lines: the line of each stamp.
        epoch_ns: the export's epoch (ns since 1970).
        frames: the run's frame times (s since the start, sorted): a mixed file whose stamps all
            match one once divided by 1e9 is named as nanoseconds.

    Raises:
        ConfigError: the file mixes the two clocks (naming the first stamp on the other clock).
    """
    if len(t_s) == 0:
        return Clock()
    big = np.asarray(t_s) >= EPOCH_MIN_S
    if big.all():
        return Clock(int(epoch_ns))
    if not big.any():
        return Clock()
    first = int(np.argmin(np.asarray(lines)))  # the first stamp in file order sets the file's clock
    other = big != big[first]
    i = int(np.flatnonzero(other)[np.argmin(np.asarray(lines)[other])])
    hint = ""
    if frames is not None and len(frames) and matched(frames, np.asarray(t_s) / 1e9).all():
        hint = "; the file's stamps look like nanoseconds since the start"
    raise ConfigError(
        f"{path}:{int(lines[i])}: time {float(t_s[i]):.6f} s is on another clock than line {int(lines[first])}'s "
        f"{float(t_s[first]):.6f} s (allowed: every stamp since the robot's start, below {EPOCH_MIN_S:g} s, or "
        f"every stamp on the export's clock, since 1970){hint}"
    )


def since_start_s(t_s: NDArray[np.float64], clock: Clock) -> NDArray[np.float64]:
    """Stamps in seconds on ``clock`` as seconds since the robot's start."""
    t = np.asarray(t_s, dtype=np.float64)
    return t - clock.epoch_ns / 1e9 if clock.epoch_ns else t


def since_start_ns(ns: NDArray[np.int64], clock: Clock) -> NDArray[np.float64]:
    """Integer nanosecond stamps on ``clock`` as seconds since the robot's start (the epoch taken off exactly)."""
    return (np.asarray(ns, dtype=np.int64) - np.int64(clock.epoch_ns)) / 1e9


def ns_clock(path: str | Path, ns: NDArray[np.int64], lines: NDArray[np.int64], epoch_ns: int) -> Clock:
    """``file_clock`` of integer nanosecond stamps."""
    return file_clock(path, np.asarray(ns, dtype=np.float64) / 1e9, lines, epoch_ns)


def nearest_frames(frames: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.int64]:
    """Index of the nearest of ``frames`` (sorted, not empty) to each of ``t``."""
    k = np.clip(np.searchsorted(frames, t), 1, max(len(frames) - 1, 1)) if len(frames) > 1 else np.zeros(len(t), int)
    left = np.maximum(k - 1, 0)
    return np.where(np.abs(t - frames[left]) <= np.abs(frames[k] - t), left, k).astype(np.int64)


def matched(frames: NDArray[np.float64], t: NDArray[np.float64], tol: float = MATCH_TOL_S) -> NDArray[np.bool_]:
    """Whether each of ``t`` lies within ``tol`` of one of ``frames`` (sorted; none match when empty)."""
    t = np.asarray(t, dtype=np.float64)
    if len(frames) == 0:
        return np.zeros(len(t), dtype=bool)
    return np.abs(frames[nearest_frames(frames, t)] - t) <= tol


def no_frame(t_read: float, clock: Clock, robot: str, frames: NDArray[np.float64], tol: float = MATCH_TOL_S) -> str:
    """Why a stamp (``t_read`` as the file gives it, in s) matches no frame of ``robot``: one clause."""
    t = float(since_start_s(np.asarray([t_read]), clock)[0])
    f = float(frames[nearest_frames(frames, np.asarray([t]))[0]])
    rate = f", every {float(np.median(np.diff(frames))):.6f} s" if len(frames) > 1 else ""
    text = (
        f"time {t:.6f} s of robot {robot} matches no frame within {tol:g} s (nearest frame {f:.6f} s, "
        f"{abs(t - f):.6f} s {'before' if f < t else 'after'} it; the robot's frames run {frames[0]:.6f} to "
        f"{frames[-1]:.6f} s{rate}; the file's clock: {clock.describe()})"
    )
    as_ns = t_read / 1e9  # a stamp in nanoseconds read as seconds, back (beyond the first frame: not ambiguous)
    if t_read > frames[-1] + tol and as_ns > frames[0] + tol and matched(frames, np.asarray([as_ns]), tol)[0]:
        text += f"; it looks like nanoseconds ({t_read:.0f} ns is {as_ns:.6f} s, a frame's time)"
    return text
