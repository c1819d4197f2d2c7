"""ORB keypoints and descriptors of a keyframe, each with its 3D point from depth.

Detection and description are OpenCV's ORB (oriented FAST + rotated BRIEF, 256-bit
descriptors stored as 32 uint8). Kimera-Multi's D455 settings: 700 features, scale factor
1.2, 8 pyramid levels. A keypoint keeps its 3D point when the depth image has a valid
reading (> 0, finite) at the keypoint's nearest pixel; keypoints without one are dropped,
since verification is 3D-3D.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import MappingError
from roman_sim.sensors import Intrinsics, backproject_pixels

#: Bytes of one ORB descriptor (256 bits).
DESCRIPTOR_BYTES = 32


class OrbParams(StrictModel):
    """ORB detector settings (OpenCV names; defaults: Kimera-Multi's D455 values)."""

    n_features: int = Field(700, ge=10, le=100_000, description="features per keyframe")
    scale_factor: float = Field(1.2, gt=1.0, le=2.0, description="pyramid decimation ratio")
    n_levels: int = Field(8, ge=1, le=16, description="pyramid levels")
    edge_threshold: int = Field(31, ge=1, le=200, description="border without features (px)")
    fast_threshold: int = Field(20, ge=1, le=255, description="FAST corner threshold")


@dataclass
class KeyframeFeatures:
    """ORB features of one keyframe that have depth.

    Attributes:
        uv: (n, 2) float32 keypoint pixels (column, row).
        descriptors: (n, 32) uint8 ORB descriptors.
        points: (n, 3) float32 back-projected points in the camera (RDF) frame.
    """

    uv: NDArray[np.float32]
    descriptors: NDArray[np.uint8]
    points: NDArray[np.float32]

    def __len__(self) -> int:
        return len(self.descriptors)


def make_orb(params: OrbParams | None = None) -> Any:
    """An OpenCV ORB detector with ``params``."""
    p = params or OrbParams()
    return cv2.ORB_create(  # type: ignore[attr-defined]
        nfeatures=p.n_features, scaleFactor=p.scale_factor, nlevels=p.n_levels,
        edgeThreshold=p.edge_threshold, patchSize=31, fastThreshold=p.fast_threshold)


def to_gray(rgb: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """(H, W, 3) RGB or (H, W) grey uint8 -> (H, W) grey uint8."""
    img = np.asarray(rgb)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] != 3):
        raise MappingError(f"ORB needs an (H, W, 3) or (H, W) uint8 image, got {img.dtype} {img.shape}")
    gray = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    return np.asarray(gray, dtype=np.uint8)


def orb_descriptors(image: NDArray[np.uint8], orb: Any) -> tuple[NDArray[np.float32], NDArray[np.uint8]]:
    """Keypoint pixels (n, 2) and descriptors (n, 32) of an image (no depth needed)."""
    kps, desc = orb.detectAndCompute(to_gray(image), None)
    if desc is None or not kps:
        return np.zeros((0, 2), np.float32), np.zeros((0, DESCRIPTOR_BYTES), np.uint8)
    uv = np.array([k.pt for k in kps], dtype=np.float32)
    return uv, np.ascontiguousarray(desc, dtype=np.uint8)


def extract_features(rgb: NDArray[np.uint8], depth: NDArray[np.floating], intrinsics: Intrinsics,
                     orb: Any) -> KeyframeFeatures:
    """ORB features of one RGB-D keyframe, keeping those with valid depth.

    Args:
        rgb: (H, W, 3) uint8 colour image.
        depth: (H, W) depth along the optical axis in metres (0 or non-finite = invalid).
        intrinsics: camera intrinsics matching the images.
        orb: detector from ``make_orb``.

    Raises:
        MappingError: image and depth shapes disagree with the intrinsics.
    """
    shape = (intrinsics.height, intrinsics.width)
    d = np.asarray(depth)
    if d.shape != shape or np.asarray(rgb).shape[:2] != shape:
        raise MappingError(f"keyframe: rgb {np.asarray(rgb).shape} / depth {d.shape} do not match intrinsics {shape}")
    uv, desc = orb_descriptors(rgb, orb)
    col = np.clip(np.rint(uv[:, 0]).astype(np.int64), 0, shape[1] - 1)
    row = np.clip(np.rint(uv[:, 1]).astype(np.int64), 0, shape[0] - 1)
    z = d[row, col].astype(np.float64)
    ok = np.isfinite(z) & (z > 0)
    pts = backproject_pixels(uv[ok], z[ok], intrinsics).astype(np.float32)
    return KeyframeFeatures(uv[ok], desc[ok], pts)
