"""``Submap``: the contract between mapping, alignment and evaluation.

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
class KeyframeSet:
    """Visual keyframes of one submap (robot data, no truth): what the visual method shares.

    Per keyframe i, its features are rows ``feat_offsets[i]:feat_offsets[i+1]`` of ``uv``,
    ``descriptors`` and ``points``, and its sparse BoW vector is rows
    ``bow_offsets[i]:bow_offsets[i+1]`` of ``bow_words`` / ``bow_values``.

    Attributes:
        t: (m,) keyframe times (s).
        T_submap_cam: (m, 4, 4) camera (RDF) poses in the submap frame, from odometry.
        intrinsics: (m, 4) fx, fy, cx, cy of each keyframe's camera.
        bow_offsets: (m + 1,) int64 offsets into the BoW arrays.
        bow_words: (B,) int32 sorted word ids per keyframe.
        bow_values: (B,) float32 L1-normalised tf-idf values.
        feat_offsets: (m + 1,) int64 offsets into the feature arrays.
        uv: (F, 2) float32 keypoint pixels.
        descriptors: (F, 32) uint8 ORB descriptors.
        points: (F, 3) float32 keypoints' 3D points in their camera frame.
    """

    t: NDArray[np.float64]
    T_submap_cam: NDArray[np.float64]
    intrinsics: NDArray[np.float64]
    bow_offsets: NDArray[np.int64]
    bow_words: NDArray[np.int32]
    bow_values: NDArray[np.float32]
    feat_offsets: NDArray[np.int64]
    uv: NDArray[np.float32]
    descriptors: NDArray[np.uint8]
    points: NDArray[np.float32]

    #: Array fields, in storage order.
    FIELDS = (
        "t",
        "T_submap_cam",
        "intrinsics",
        "bow_offsets",
        "bow_words",
        "bow_values",
        "feat_offsets",
        "uv",
        "descriptors",
        "points",
    )

    def __len__(self) -> int:
        return int(len(self.t))

    def bow(self, i: int) -> tuple[NDArray[np.int32], NDArray[np.float32]]:
        """Word ids and values of keyframe ``i``'s BoW vector."""
        s, e = self.bow_offsets[i], self.bow_offsets[i + 1]
        return self.bow_words[s:e], self.bow_values[s:e]

    def features(self, i: int) -> tuple[NDArray[np.float32], NDArray[np.uint8], NDArray[np.float32]]:
        """(uv, descriptors, points) of keyframe ``i``."""
        s, e = self.feat_offsets[i], self.feat_offsets[i + 1]
        return self.uv[s:e], self.descriptors[s:e], self.points[s:e]


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
        keyframes: optional visual keyframes (ORB features, BoW vectors) of the submap.
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
    keyframes: KeyframeSet | None = None
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
