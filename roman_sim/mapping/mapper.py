"""``Mapper``: one robot's front end (segment, observe, track) and the ``SegmentMap`` it makes."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError, MappingError
from roman_sim.core.sensors import Frame, check_frame
from roman_sim.core.trajectory import Trajectory
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.observation import observe_indexed
from roman_sim.mapping.protocols import Segmenter, SemanticEncoder, reads_truth
from roman_sim.mapping.segment import Segment
from roman_sim.mapping.tracker import MappingConfig, Observation, Tracker

log = logging.getLogger(__name__)


def _stack(poses: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """(N, 4, 4) stack of ``poses`` ((0, 4, 4) when there are none)."""
    return np.stack(poses) if poses else np.zeros((0, 4, 4))


@dataclass
class SegmentMap:
    """Finished segments of one robot plus its trajectories.

    Attributes:
        robot: robot name.
        segments: finished segments (odometry frame), sorted by id.
        times: (N,) frame times (s).
        T_odom_body: (N, 4, 4) odometry poses (what the robot believes).
        T_world_body: (N, 4, 4) true poses (evaluation only), or None when the frames
            carried no ground truth.
    """

    robot: str
    segments: list[Segment]
    times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    T_odom_body: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 4, 4)))
    T_world_body: NDArray[np.float64] | None = field(default_factory=lambda: np.zeros((0, 4, 4)))

    def __len__(self) -> int:
        return len(self.segments)

    @property
    def odometry(self) -> Trajectory:
        """The odometry trajectory ``T_odom_body``."""
        return Trajectory(self.times, self.T_odom_body)

    @property
    def truth(self) -> Trajectory | None:
        """The true trajectory ``T_world_body`` (None without ground truth)."""
        return None if self.T_world_body is None else Trajectory(self.times, self.T_world_body)

    @property
    def trajectory_length_m(self) -> float:
        """Length of the true trajectory (m), or of the odometry when there is no truth."""
        T = self.T_world_body if self.T_world_body is not None else self.T_odom_body
        if len(T) < 2:
            return 0.0
        return float(np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1).sum())


class Mapper:
    """Builds a ``SegmentMap`` frame by frame.

    Args:
        cfg: front-end parameters.
        segmenter: any ``Segmenter`` (e.g. ``simulated_segmenter("fastsam", seed)``, ``roman_sim.frontend``).
        encoder: any ``SemanticEncoder``, or None for no descriptors.
        seed: kept for reproducibility of user components (the built-ins are seeded).
        on_frame: called after each frame as ``on_frame(frame, masks, observed)`` with the
            frame as given (truth included), the segmenter's masks and ``observed``, the
            (mask index, descriptor or None) of every mask that gave an observation: the
            hook of front-end grading.
        reshape: called as ``reshape(frame, observations)`` before tracking, returning the
            observations to track: how a counterfactual (``MappingConfig.whole_surface``, ``complete``)
            replaces their points; required when either is set.

    The segmenter sees ``frame.public()`` (no ground truth) unless it declares
    ``reads_truth``; the encoder gets truth-derived contexts only if it declares it.
    """

    def __init__(
        self,
        cfg: MappingConfig,
        segmenter: Segmenter,
        encoder: SemanticEncoder | None = None,
        seed: int = 0,
        on_frame: Callable[[Frame, list[Mask], list[tuple[int, NDArray[np.float32] | None]]], None] | None = None,
        reshape: Callable[[Frame, list[Observation]], list[Observation]] | None = None,
    ) -> None:
        if cfg.whole_surface and reshape is None:
            raise ConfigError(
                "mapping.whole_surface: a counterfactual of the simulator; it needs simulated frames and "
                "their world (allowed here: false)"
            )
        if cfg.complete and reshape is None:
            raise ConfigError(
                "mapping.complete: a counterfactual of the simulator; it needs simulated frames and "
                "their world (allowed here: [])"
            )
        self.cfg = cfg
        self.segmenter = segmenter
        self.encoder = encoder
        self.seed = seed
        self.on_frame = on_frame
        self.reshape = reshape
        self.tracker = Tracker(cfg)
        self.robot: str | None = None
        self._t: list[float] = []
        self._odom: list[NDArray[np.float64]] = []
        self._world: list[NDArray[np.float64]] | None = []
        self._done = False

    def process(self, frame: Frame) -> int:
        """Fuse one frame; returns the number of observations it produced."""
        if self._done:
            raise MappingError("mapper: process() called after finish()")
        if self.robot is None:
            self.robot = frame.robot
        elif frame.robot != self.robot:
            raise MappingError(f"mapper: frame of robot {frame.robot!r} given to the map of {self.robot!r}")
        if self._t and frame.t < self._t[-1]:
            raise MappingError(f"mapper: frame {frame.index} time {frame.t} goes back in time")
        check_frame(frame)
        if self._t and (frame.truth is None) != (self._world is None):
            raise MappingError(
                f"mapper: frame {frame.index} of robot {frame.robot}: frames with and "
                "without ground truth mixed in one map"
            )
        if not self._t and frame.truth is None:
            self._world = None
        masks = self.segmenter.segment(frame if reads_truth(self.segmenter) else frame.public())
        indexed = observe_indexed(frame, masks, self.cfg, self.encoder)
        obs = [o for _, o in indexed]
        if self.on_frame is not None:
            self.on_frame(frame, masks, [(k, o.descriptor) for k, o in indexed])
        if self.reshape is not None:
            obs = self.reshape(frame, obs)
        self._t.append(float(frame.t))
        self._odom.append(np.asarray(frame.T_odom_body, dtype=np.float64))
        if frame.truth is not None and self._world is not None:
            self._world.append(np.asarray(frame.truth.T_world_body, dtype=np.float64))
        self.tracker.update(obs, float(frame.t), self._odom[-1][:3, 3])
        return len(obs)

    def finish(self) -> SegmentMap:
        """Finalise every segment and return the map (the mapper is then closed)."""
        self._done = True
        segs = self.tracker.flush()
        log.info("robot %s: %d frames, %d segments", self.robot, len(self._t), len(segs))
        return SegmentMap(
            self.robot or "",
            segs,
            np.asarray(self._t, dtype=np.float64),
            _stack(self._odom),
            None if self._world is None else _stack(self._world),
        )
