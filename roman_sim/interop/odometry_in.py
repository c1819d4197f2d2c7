"""A robot's odometry brought back in: a TUM trajectory from outside in place of the robot's own.

``robots.N.odometry: FILE.tum`` in a scenario (or ``roman-sim run --odometry ROBOT=FILE.tum``)
gives robot N the poses of ``FILE`` as its odometry (``Frame.T_odom_body``), e.g. what a VIO
system estimated on the robot's exported sequence: the mapper, the submaps, the pose graph and
the ATE's odometry rows then run on them, whatever the robot's frames come from.

The file is evo's TUM format, ``t x y z qx qy qz qw`` per line, of the body (``frame: body``,
the default; the IMU of an EuRoC export is the body frame) or of the camera (``frame:
camera``, TUM's convention: ``T_odom_body = T_odom_cam @ inv(T_body_cam)``). Its stamps are
read on either clock (``roman_sim.interop.stamps``): the export's (``EXPORT_EPOCH_NS`` plus
the time since the robot's start, as a system run on an export stamps its output) or seconds
since the robot's start.

Each frame takes the file's pose nearest its time within ``max_time_diff_s`` (by default
0.01 s, the ATE's association tolerance); a frame without one is left out of the map. The
file is refused, in one line that names it, when its stamps are nanoseconds, when a stamp
matches no frame within the tolerance (the first, by line; a file with more poses than the
robot has frames, e.g. at an IMU's rate, is instead taken at the frames it has a pose for),
and when it gives fewer than ``min_share`` of the robot's frames a pose (the share it covers
and the share required).
"""

from __future__ import annotations

import gzip
import hashlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.geometry import inv_T
from roman_sim.core.sensors import Frame, FrameSourceView
from roman_sim.core.tum import parse_tum
from roman_sim.interop.base import EXPORT_EPOCH_NS
from roman_sim.interop.stamps import (
    EPOCH_MIN_S,
    MATCH_TOL_S,
    Clock,
    file_clock,
    matched,
    nearest_frames,
    no_frame,
    since_start_s,
)

#: Share of a robot's frames an odometry file must give a pose, unless the scenario says otherwise.
MIN_SHARE = 0.9


class OdometryFile(StrictModel):
    """A TUM trajectory that replaces a robot's odometry (a plain path stands for ``{file: path}``)."""

    file: Path
    frame: Literal["body", "camera"] = Field("body", description="the poses are the body's or the camera's")
    max_time_diff_s: float = Field(MATCH_TOL_S, gt=0, le=1.0, description="a frame takes a pose this close in time")
    min_share: float = Field(MIN_SHARE, gt=0, le=1.0, description="share of the robot's frames that need a pose")
    sha256: str | None = Field(None, description="the file's SHA-256: filled in when a run resolves the scenario")

    @model_validator(mode="before")
    @classmethod
    def _path_alone(cls, v: Any) -> Any:
        return {"file": v} if isinstance(v, (str, Path)) else v

    def read_bytes(self) -> bytes:
        """The file's bytes (ConfigError naming the field when it cannot be read)."""
        try:
            return self.file.read_bytes()
        except OSError as err:
            raise ConfigError(f"odometry.file {self.file}: cannot be read ({err.strerror or err})") from None

    def digest(self) -> str:
        """The SHA-256 of the file's bytes (what a run's cache keys hash)."""
        return hashlib.sha256(self.read_bytes()).hexdigest()

    def describe(self) -> str:
        """The odometry in words, for the report."""
        sha = "" if self.sha256 is None else f", SHA-256 {self.sha256[:12]}"
        return f"from {self.file} ({self.frame} poses{sha}; a frame takes the pose within {self.max_time_diff_s:g} s)"


@dataclass(frozen=True)
class MatchedOdometry:
    """An odometry file matched to a robot's frames.

    Attributes:
        keep: (K,) ascending indices of the frames that have a pose.
        T_odom_body: (K, 4, 4) their body poses from the file.
        n_frames: the robot's frames in all.
        clock: the clock of the file's stamps.
    """

    keep: NDArray[np.int64]
    T_odom_body: NDArray[np.float64]
    n_frames: int
    clock: Clock


def match_odometry(
    cfg: OdometryFile,
    robot: str,
    times: NDArray[np.float64],
    T_body_cam: NDArray[np.float64],
    epoch_ns: int = EXPORT_EPOCH_NS,
) -> MatchedOdometry:
    """The poses of ``cfg.file`` at the robot's frame ``times`` (s since its start, ascending).

    Raises:
        ConfigError: one line naming the file: unreadable or malformed, changed since the run
            resolved it (``sha256``), stamps in nanoseconds, a stamp that matches no frame, or
            too few frames with a pose.
    """
    path, raw = cfg.file, cfg.read_bytes()
    if cfg.sha256 is not None and hashlib.sha256(raw).hexdigest() != cfg.sha256:
        raise ConfigError(f"odometry.file {path}: changed since the run read it; run the command again")
    try:
        text = (gzip.decompress(raw) if path.suffix == ".gz" else raw).decode("utf-8")
        read = parse_tum(text, str(path))
    except (StorageError, OSError, EOFError, UnicodeDecodeError) as err:
        raise ConfigError(str(err) if isinstance(err, StorageError) else f"{path}: unreadable ({err})") from None
    lines = pose_lines(text)
    times = np.asarray(times, dtype=np.float64)
    if len(read) == 0 or len(times) == 0:
        raise ConfigError(f"{path}: no pose for robot {robot} (a TUM line per pose: t x y z qx qy qz qw)")
    tol = cfg.max_time_diff_s
    _not_nanoseconds(path, read.t, lines, times, epoch_ns, tol)
    clock = file_clock(path, read.t, lines, epoch_ns, times)
    t = since_start_s(read.t, clock)
    if len(t) <= len(times):  # no denser than the frames: every pose is one of a frame
        ok = matched(times, t, tol)
        if not ok.all():
            i = int(np.flatnonzero(~ok)[0])
            raise ConfigError(f"{path}:{int(lines[i])}: {no_frame(float(read.t[i]), clock, robot, times, tol)}")
    have = matched(t, times, tol)  # per frame: a pose within the tolerance
    share = float(have.mean())
    if share < cfg.min_share:
        raise ConfigError(
            f"{path}: covers {share:.0%} of robot {robot}'s frames ({int(have.sum())} of {len(times)} "
            f"within {tol:g} s; "
            f"the file runs {t[0]:.3f} to {t[-1]:.3f} s, the robot {times[0]:.3f} to {times[-1]:.3f} s); "
            f"required: at least {cfg.min_share:.0%} (odometry.min_share)"
        )
    keep = np.flatnonzero(have).astype(np.int64)
    T = read.T[nearest_frames(t, times[keep])]
    if cfg.frame == "camera":
        T = T @ inv_T(np.asarray(T_body_cam, dtype=np.float64))
    return MatchedOdometry(keep, T, len(times), clock)


def _not_nanoseconds(
    path: Path,
    t_read: NDArray[np.float64],
    lines: NDArray[np.int64],
    times: NDArray[np.float64],
    epoch_ns: int,
    tol: float,
) -> None:
    """ConfigError when the stamps give more of the frames a pose read as nanoseconds than as seconds."""
    as_s, as_ns = _on_clock(t_read, epoch_ns), _on_clock(t_read / 1e9, epoch_ns)
    if matched(as_ns, times, tol).mean() > max(matched(as_s, times, tol).mean(), 0.5):
        raise ConfigError(
            f"{path}:{int(lines[-1])}: time {t_read[-1]:.0f} is in nanoseconds ({as_ns[-1]:.6f} s, within the "
            "robot's drive); TUM stamps are seconds (since 1970 on the export's clock, or since the robot's start)"
        )


def _on_clock(t: NDArray[np.float64], epoch_ns: int) -> NDArray[np.float64]:
    """Stamps in seconds since the robot's start, taking the epoch off when every one is on the export's clock."""
    return t - epoch_ns / 1e9 if (t >= EPOCH_MIN_S).all() else t


def pose_lines(text: str) -> NDArray[np.int64]:
    """The line of each pose of a TUM text (lines that are neither empty nor comments), in order."""
    lines = [n for n, ln in enumerate(text.splitlines(), start=1) if ln.strip() and not ln.strip().startswith("#")]
    return np.asarray(lines, dtype=np.int64)


@dataclass(frozen=True, eq=False)
class WithOdometry(FrameSourceView):
    """A ``FrameSource``: ``inner``'s frames that have a pose from outside, each carrying it as ``T_odom_body``.

    Frames keep their index in ``inner`` (the simulated front end draws per frame index);
    ``frames(indices)`` takes indices of this source (``0 .. len - 1``).
    """

    odometry: MatchedOdometry

    def __len__(self) -> int:
        return len(self.odometry.keep)

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[Frame]:
        """The kept frames in order (all of ``inner``'s are read, so each is the frame of a whole read), or
        those at ``indices``."""
        keep, T = self.odometry.keep, self.odometry.T_odom_body
        if indices is None:
            at = {int(k): i for i, k in enumerate(keep)}
            for k, frame in enumerate(self.inner.frames()):
                if k in at:
                    yield replace(frame, T_odom_body=T[at[k]].copy())
            return
        pos = np.asarray(list(indices), dtype=np.int64)
        for i, frame in zip(pos, self.inner.frames(keep[pos].tolist())):
            yield replace(frame, T_odom_body=T[i].copy())
