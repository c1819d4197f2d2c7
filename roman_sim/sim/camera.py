"""Pinhole camera model: configuration, intrinsics, mount, projection and back-projection.

Pixel convention (OpenCV): pixel ``(u, v)`` = (column, row) has its centre at integer
coordinates, so the image spans ``[-0.5, W - 0.5] x [-0.5, H - 0.5]`` and a centred
principal point is ``((W - 1) / 2, (H - 1) / 2)``. The camera optical frame is RDF
(x right, y down, z forward); depth is the z coordinate (along the optical axis).
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.geometry import R_FLU_RDF, make_T, rot_y
from roman_sim.core.sensors import Intrinsics, check_intrinsics

log = logging.getLogger(__name__)

#: Allowed pixel aspect fy / fx of a camera given an explicit ``vfov_deg`` (real cameras' is 1).
PIXEL_ASPECT = (0.5, 2.0)


class DepthNoiseConfig(StrictModel):
    """Depth sensor noise (RealSense-like stereo depth).

    ``std = std_at_ref * (z / ref_range_m)^2``; readings are quantised to ``quantum_m``;
    pixels whose 3x3 neighbourhood spans more than ``edge_jump_m`` are invalidated
    (mixed pixels at depth edges); readings beyond the camera's ``max_depth_m`` are invalid.
    """

    enabled: bool = True
    std_at_ref_m: float = Field(0.08, ge=0.0, le=1.0)
    ref_range_m: float = Field(4.0, gt=0.0, le=100.0)
    quantum_m: float = Field(0.001, ge=0.0, le=0.1)
    edge_jump_m: float = Field(0.3, gt=0.0, le=100.0)


class CameraConfig(StrictModel):
    """Camera intrinsics and its mount on the robot body (FLU).

    The field of view is one angle, ``hfov_deg`` (horizontal), and the aspect is the image's
    (``width / height``): pixels are square (fx = fy), as a real camera's are. Defaults follow an
    Intel RealSense D455 depth stream at 4:3: 640 x 480 and its 87 deg horizontal field of view,
    so the vertical one is 2 atan(tan(43.5 deg) * 3 / 4) = 70.9 deg. (The D455's quoted 87 x 58 deg
    belong to its 16:9 image, where square pixels give 56.2 deg vertical.) ``vfov_deg`` asks for a
    vertical field of view explicitly, which makes the pixels non-square (fy != fx); their aspect
    fy / fx must lie within ``PIXEL_ASPECT``.
    """

    width: int = Field(640, ge=8, le=4096)
    height: int = Field(480, ge=8, le=4096)
    hfov_deg: float = Field(87.0, gt=1.0, lt=179.0, description="horizontal field of view")
    vfov_deg: float | None = Field(
        None,
        gt=1.0,
        lt=179.0,
        description="vertical field of view, for non-square pixels (null: square pixels, from the image's aspect)",
    )
    mount_height_m: float = Field(0.4, ge=0.0, le=5.0)
    mount_forward_m: float = Field(0.2, ge=-2.0, le=2.0)
    mount_pitch_deg: float = Field(0.0, ge=-60.0, le=60.0)
    max_depth_m: float = Field(7.5, gt=0.1, le=200.0)
    far_m: float = Field(100.0, gt=1.0, le=10000.0)
    near_m: float = Field(0.05, gt=0.0, le=1.0)
    depth_noise: DepthNoiseConfig = Field(default_factory=DepthNoiseConfig)

    @model_validator(mode="after")
    def _pixel_aspect(self) -> CameraConfig:
        if self.vfov_deg is None:
            return self
        fx, fy = self._focal()
        lo, hi = PIXEL_ASPECT
        if not lo <= fy / fx <= hi:
            square = 2.0 * np.degrees(np.arctan((self.height / 2.0) / fx))
            raise ValueError(
                f"vfov_deg ({self.vfov_deg:g}) with hfov_deg {self.hfov_deg:g} at {self.width} x {self.height} "
                f"gives pixels of aspect fy/fx {fy / fx:.3g}: allowed {lo:g} to {hi:g} "
                f"(null: square pixels, {square:.1f} deg vertical)"
            )
        return self

    def _focal(self) -> tuple[float, float]:
        """(fx, fy) in pixels: fx from ``hfov_deg``, fy = fx unless ``vfov_deg`` is given."""
        fx = float((self.width / 2.0) / np.tan(np.radians(self.hfov_deg) / 2.0))
        if self.vfov_deg is None:
            return fx, fx
        return fx, float((self.height / 2.0) / np.tan(np.radians(self.vfov_deg) / 2.0))

    def intrinsics(self) -> Intrinsics:
        """Pinhole intrinsics with a centred principal point (square pixels unless ``vfov_deg`` is given)."""
        fx, fy = self._focal()
        cx, cy = (self.width - 1) / 2.0, (self.height - 1) / 2.0
        return check_intrinsics(Intrinsics(self.width, self.height, fx, fy, cx, cy))

    def T_body_cam(self) -> NDArray[np.float64]:
        """4x4 pose of the camera optical frame (RDF) in the body frame (FLU).

        A positive ``mount_pitch_deg`` tilts the camera down (rotation about body +y).
        """
        R = rot_y(np.radians(self.mount_pitch_deg)) @ R_FLU_RDF
        return make_T(R, [self.mount_forward_m, 0.0, self.mount_height_m])


class StereoConfig(StrictModel):
    """A second camera beside the first: the same intrinsics and orientation, ``baseline_m``
    to its right (along the first camera's optical x axis), rendered like the first.

    The default is an Intel RealSense D455's stereo baseline, 95 mm.
    """

    baseline_m: float = Field(0.095, gt=0.0, le=5.0)

    def T_cam_cam2(self) -> NDArray[np.float64]:
        """4x4 pose of the second camera in the first camera's optical frame (a shift by +baseline in x)."""
        return make_T(np.eye(3), [self.baseline_m, 0.0, 0.0])
