"""Camera intrinsics and the per-step sensor ``Frame``: the contract between W2 and W3."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics (pixels). Pixel (u, v) = (column, row); principal point (cx, cy)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @property
    def K(self) -> NDArray[np.float64]:
        """3x3 camera matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def fov_deg(self) -> tuple[float, float]:
        """(horizontal, vertical) field of view in degrees."""
        return (
            float(np.degrees(2 * np.arctan(self.width / (2 * self.fx)))),
            float(np.degrees(2 * np.arctan(self.height / (2 * self.fy)))),
        )


@dataclass
class Frame:
    """One sensor step of one robot.

    Attributes:
        robot: robot name.
        index: step index (0-based).
        t: time in seconds.
        rgb: (H, W, 3) uint8, or None when RGB is not rendered.
        depth: (H, W) float32 metric depth along the optical axis; 0 marks invalid pixels.
        object_ids: (H, W) int32 true object id per pixel, -1 for background (terrain, sky).
            Ground truth: a segmenter model may use it, an aligner never sees it.
        T_world_body: 4x4 true body pose.
        T_odom_body: 4x4 drifted odometry pose (what the robot believes).
        T_body_cam: 4x4 camera (RDF optical) pose in the body (FLU) frame.
        intrinsics: the camera intrinsics.
    """

    robot: str
    index: int
    t: float
    rgb: NDArray[np.uint8] | None
    depth: NDArray[np.float32]
    object_ids: NDArray[np.int32]
    T_world_body: NDArray[np.float64]
    T_odom_body: NDArray[np.float64]
    T_body_cam: NDArray[np.float64]
    intrinsics: Intrinsics

    @property
    def T_odom_cam(self) -> NDArray[np.float64]:
        """Camera pose in the odometry frame."""
        return self.T_odom_body @ self.T_body_cam

    @property
    def T_world_cam(self) -> NDArray[np.float64]:
        """True camera pose in the world frame."""
        return self.T_world_body @ self.T_body_cam
