"""``Submap``: the contract between mapping (W3), alignment (W4) and evaluation (W5).

A submap is what a robot would send to another: segment centres and features in the
submap's gravity-aligned frame. Evaluation-only truth is kept in ``truth`` and stripped by
``public()`` before any aligner sees the submap.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray


@dataclass
class SubmapTruth:
    """Evaluation-only facts of a submap.

    Attributes:
        T_world_submap: 4x4 gravity-aligned true pose of the submap centre.
        object_ids: (n,) majority true object id of each segment (-1 if none).
        purity: (n,) fraction of the segment's points from that object.
    """

    T_world_submap: NDArray[np.float64]
    object_ids: NDArray[np.int64]
    purity: NDArray[np.float64]


@dataclass
class Submap:
    """Segments of one robot near one centre pose, in the submap's gravity-aligned frame.

    Attributes:
        robot: robot name.
        index: submap index within the robot's sequence.
        t: time (s) of the centre pose.
        T_odom_submap: 4x4 gravity-aligned centre pose in the robot's odometry frame.
        segment_ids: (n,) ids of the segments (unique within the robot's map).
        centers: (n, 3) segment centres in the submap frame.
        volumes: (n,) oriented-box volumes (m^3).
        shape: (n, 3) PCA linearity, planarity, scattering.
        descriptors: (n, D) unit semantic descriptors (float32 or float16).
        extents: (n, 3) oriented-box extents, sorted descending.
        points: optional per-segment (k_i, 3) points in the submap frame (for drawing).
        truth: evaluation-only truth, or None when stripped.
    """

    robot: str
    index: int
    t: float
    T_odom_submap: NDArray[np.float64]
    segment_ids: NDArray[np.int64]
    centers: NDArray[np.float64]
    volumes: NDArray[np.float64]
    shape: NDArray[np.float64]
    descriptors: NDArray[np.floating]
    extents: NDArray[np.float64]
    points: list[NDArray[np.float64]] | None = None
    truth: SubmapTruth | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return int(len(self.centers))

    @property
    def name(self) -> str:
        """``robot/index``, unique within a run."""
        return f"{self.robot}/{self.index}"

    def public(self) -> "Submap":
        """A copy without evaluation truth: what an aligner may see."""
        return replace(self, truth=None)
