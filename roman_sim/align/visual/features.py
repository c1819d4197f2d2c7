"""ORB keypoints and descriptors of a keyframe, each with its 3D point from depth.

Detection and description are OpenCV's ORB (oriented FAST + rotated BRIEF, 256-bit
descriptors stored as 32 uint8). Kimera-Multi's D455 settings: 700 features, scale factor
1.2, 8 pyramid levels. A keypoint keeps its 3D point when the depth image has a valid
reading (> 0, finite) at the keypoint's nearest pixel; keypoints without one are dropped,
since verification is 3D-3D.

Two defaults differ from Kimera-Multi's (FAST threshold 20, detection on the whole
image), for a measured reason: the simulated surfaces have less local contrast than real
ones, so at threshold 20 ORB's 700 strongest corners sit on silhouettes against the sky
and on objects beyond the depth range (on the textured demo world at 640 x 480: a median
of 6 keypoints per frame with depth). Detecting with threshold 5 inside the valid-depth
region (eroded by ``mask_erode_px``) spends the 700-feature budget on keypoints that can
be verified (median 268 per frame there). ``fast_threshold=20, depth_mask=False`` gives
Kimera-Multi's detector.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import MappingError
from roman_sim.core.sensors import Intrinsics, backproject_pixels

#: Bytes of one ORB descriptor (256 bits).
DESCRIPTOR_BYTES = 32


class OrbParams(StrictModel):
    """ORB detector settings (OpenCV names; defaults: Kimera-Multi's D455 values)."""

    n_features: int = Field(700, ge=10, le=100_000, description="features per keyframe")
    scale_factor: float = Field(1.2, gt=1.0, le=2.0, description="pyramid decimation ratio")
    n_levels: int = Field(8, ge=1, le=16, description="pyramid levels")
    edge_threshold: int = Field(31, ge=1, le=200, description="border without features (px)")
    fast_threshold: int = Field(5, ge=1, le=255, description="FAST corner threshold (Kimera-Multi: 20)")
    depth_mask: bool = Field(True, description="detect only where depth is valid (Kimera-Multi: whole image)")
    mask_erode_px: int = Field(2, ge=0, le=50, description="erode the valid-depth mask by this radius")


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
    import cv2  # OpenCV loads when the visual method runs, not with the package

    p = params or OrbParams()
    return cv2.ORB_create(  # type: ignore[attr-defined]
        nfeatures=p.n_features,
        scaleFactor=p.scale_factor,
        nlevels=p.n_levels,
        edgeThreshold=p.edge_threshold,
        patchSize=31,
        fastThreshold=p.fast_threshold,
    )


def to_gray(rgb: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """(H, W, 3) RGB or (H, W) grey uint8 -> (H, W) grey uint8."""
    img = np.asarray(rgb)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] != 3):
        raise MappingError(f"ORB needs an (H, W, 3) or (H, W) uint8 image, got {img.dtype} {img.shape}")
    import cv2

    gray = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    return np.asarray(gray, dtype=np.uint8)


def depth_mask(depth: NDArray[np.floating], erode_px: int) -> NDArray[np.uint8]:
    """(H, W) uint8 detection mask (255 = use): valid depth, eroded by ``erode_px``."""
    d = np.asarray(depth)
    m = (np.isfinite(d) & (d > 0)).astype(np.uint8) * 255
    if erode_px <= 0:
        return m
    import cv2

    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * erode_px + 1, 2 * erode_px + 1))
    return np.asarray(cv2.erode(m, kernel), dtype=np.uint8)


def orb_descriptors(
    image: NDArray[np.uint8], orb: Any, mask: NDArray[np.uint8] | None = None
) -> tuple[NDArray[np.float32], NDArray[np.uint8]]:
    """Keypoint pixels (n, 2) and descriptors (n, 32) of an image (inside ``mask`` when given)."""
    kps, desc = orb.detectAndCompute(to_gray(image), mask)
    if desc is None or not kps:
        return np.zeros((0, 2), np.float32), np.zeros((0, DESCRIPTOR_BYTES), np.uint8)
    uv = np.array([k.pt for k in kps], dtype=np.float32)
    return uv, np.ascontiguousarray(desc, dtype=np.uint8)


def extract_features(
    rgb: NDArray[np.uint8],
    depth: NDArray[np.floating],
    intrinsics: Intrinsics,
    orb: Any,
    params: OrbParams | None = None,
) -> KeyframeFeatures:
    """ORB features of one RGB-D keyframe, keeping those with valid depth.

    Args:
        rgb: (H, W, 3) uint8 colour image.
        depth: (H, W) depth along the optical axis in metres (0 or non-finite = invalid).
        intrinsics: camera intrinsics matching the images.
        orb: detector from ``make_orb``.
        params: the detector's settings (for the depth mask; defaults when None).

    Raises:
        MappingError: image and depth shapes disagree with the intrinsics.
    """
    shape = (intrinsics.height, intrinsics.width)
    d = np.asarray(depth)
    if d.shape != shape or np.asarray(rgb).shape[:2] != shape:
        raise MappingError(f"keyframe: rgb {np.asarray(rgb).shape} / depth {d.shape} do not match intrinsics {shape}")
    p = params or OrbParams()
    uv, desc = orb_descriptors(rgb, orb, depth_mask(d, p.mask_erode_px) if p.depth_mask else None)
    col = np.clip(np.rint(uv[:, 0]).astype(np.int64), 0, shape[1] - 1)
    row = np.clip(np.rint(uv[:, 1]).astype(np.int64), 0, shape[0] - 1)
    z = d[row, col].astype(np.float64)
    ok = np.isfinite(z) & (z > 0)
    pts = backproject_pixels(uv[ok], z[ok], intrinsics).astype(np.float32)
    return KeyframeFeatures(uv[ok], desc[ok], pts)
