"""The sensor layer: camera intrinsics, the per-step ``Frame`` and (back-)projection.

Nothing here knows the simulator: a ``Frame`` is what any RGB-D + odometry source gives
(rendered, recorded or real). Ground truth is optional and kept apart in ``frame.truth``
(like ``Submap.truth``); ``frame.public()`` strips it.

Pixel convention (OpenCV): pixel ``(u, v)`` = (column, row) has its centre at integer
coordinates, so the image spans ``[-0.5, W - 0.5] x [-0.5, H - 0.5]`` and a centred
principal point is ``((W - 1) / 2, (H - 1) / 2)``. The camera optical frame is RDF
(x right, y down, z forward); depth is the z coordinate (along the optical axis).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roman_sim.core.errors import ConfigError, MappingError


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
class FrameTruth:
    """Evaluation-only facts of a frame (a simulator has them; a real sequence may not).

    A real sequence usually has a true trajectory (motion capture, RTK) but no instance
    labels: ``object_ids`` is then None. Segments of such frames carry no object truth
    (their majority id is -1), and the evaluation scores pairs by the true poses alone.

    Attributes:
        object_ids: (H, W) int32 true object id per pixel, -1 for background (terrain, sky),
            or None when the source has no instance labels.
        T_world_body: 4x4 true body pose.
    """

    object_ids: NDArray[np.int32] | None
    T_world_body: NDArray[np.float64]


@dataclass
class Frame:
    """One sensor step of one robot.

    Attributes:
        robot: robot name.
        index: step index (0-based).
        t: time in seconds.
        rgb: (H, W, 3) uint8, or None when RGB is not available.
        depth: (H, W) float32 metric depth along the optical axis; 0 marks invalid pixels.
        T_odom_body: 4x4 odometry pose (what the robot believes; drifts).
        T_body_cam: 4x4 camera (RDF optical) pose in the body (FLU) frame.
        intrinsics: the camera intrinsics.
        truth: ground truth, or None (a real sequence, or stripped by ``public()``).
        rgb_right: (H, W, 3) uint8 of a second camera beside the first (stereo: same
            intrinsics, to the right along the optical x axis), or None.
    """

    robot: str
    index: int
    t: float
    rgb: NDArray[np.uint8] | None
    depth: NDArray[np.float32]
    T_odom_body: NDArray[np.float64]
    T_body_cam: NDArray[np.float64]
    intrinsics: Intrinsics
    truth: FrameTruth | None = None
    rgb_right: NDArray[np.uint8] | None = None

    @property
    def T_odom_cam(self) -> NDArray[np.float64]:
        """Camera pose in the odometry frame."""
        return self.T_odom_body @ self.T_body_cam

    def public(self) -> "Frame":
        """A copy without ground truth: what a front end may see."""
        return replace(self, truth=None)


@runtime_checkable
class FrameSource(Protocol):
    """One robot's stream of frames: a simulated robot, a recording or a TUM RGB-D folder.

    Everything but ``frames`` is known before a frame is produced (a simulated robot is
    driven, a folder associated, up front); ``frames`` yields one frame at a time.
    """

    @property
    def name(self) -> str:
        """The robot's name (``Frame.robot`` of every frame)."""
        ...

    @property
    def intrinsics(self) -> Intrinsics:
        """The camera intrinsics of every frame."""
        ...

    @property
    def T_body_cam(self) -> NDArray[np.float64]:
        """The camera mount: the camera (RDF optical) pose in the body (FLU) frame."""
        ...

    def __len__(self) -> int:
        """Number of frames ``frames()`` yields."""
        ...

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[Frame]:
        """The frames in order; only those at ``indices`` (ascending, each keeping its index) if given."""
        ...


@dataclass(frozen=True, eq=False)
class FrameSourceView:
    """A ``FrameSource`` over another one, ``inner``: its robot, camera and mount, and by default its frame count.

    A subclass gives ``frames`` (and ``__len__`` when it keeps fewer frames).
    """

    inner: FrameSource

    @property
    def name(self) -> str:
        """The robot's name."""
        return self.inner.name

    @property
    def intrinsics(self) -> Intrinsics:
        """The camera intrinsics."""
        return self.inner.intrinsics

    @property
    def T_body_cam(self) -> NDArray[np.float64]:
        """The camera mount."""
        return self.inner.T_body_cam

    def __len__(self) -> int:
        return len(self.inner)


def check_frame(frame: Frame) -> None:
    """Raise ``MappingError`` when the frame's arrays are inconsistent (truth checked if present)."""
    intr = frame.intrinsics
    shape = (intr.height, intr.width)
    depth = np.asarray(frame.depth)
    if depth.shape != shape:
        raise MappingError(f"frame {frame.index}: depth shape {depth.shape} does not match intrinsics {shape}")
    for key in ("rgb", "rgb_right"):
        image = getattr(frame, key)
        if image is not None and np.asarray(image).shape != (*shape, 3):
            raise MappingError(
                f"frame {frame.index}: {key} shape {np.asarray(image).shape} does not match intrinsics {shape} x 3"
            )
    poses = {"T_odom_body": frame.T_odom_body, "T_body_cam": frame.T_body_cam}
    if frame.truth is not None:
        if frame.truth.object_ids is not None and np.asarray(frame.truth.object_ids).shape != shape:
            raise MappingError(f"frame {frame.index}: truth.object_ids shape does not match intrinsics {shape}")
        poses["truth.T_world_body"] = frame.truth.T_world_body
    for name, T in poses.items():
        T = np.asarray(T)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise MappingError(f"frame {frame.index}: {name} must be a finite 4x4 matrix")


def check_intrinsics(intr: Intrinsics) -> Intrinsics:
    """Return ``intr`` if valid, else raise ``ConfigError`` naming the bad field."""
    if intr.width < 1 or intr.height < 1:
        raise ConfigError(f"intrinsics: width and height must be >= 1, got {intr.width}x{intr.height}")
    for name in ("fx", "fy"):
        v = float(getattr(intr, name))
        if not np.isfinite(v) or v <= 0:
            raise ConfigError(f"intrinsics.{name}: must be a finite positive focal length, got {v}")
    for name, lim in (("cx", intr.width), ("cy", intr.height)):
        v = float(getattr(intr, name))
        if not np.isfinite(v) or not -0.5 <= v <= lim - 0.5:
            raise ConfigError(f"intrinsics.{name}: must lie inside the image [-0.5, {lim - 0.5}], got {v}")
    return intr


def project(K: ArrayLike, pts_cam: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Project camera-frame (RDF) points to pixels.

    Args:
        K: 3x3 camera matrix.
        pts_cam: (N, 3) points in the camera frame.

    Returns:
        (N, 2) pixel coordinates (u, v) and an (N,) mask of points in front (z > 0).
        Pixels of points behind the camera are NaN.
    """
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3):
        raise ConfigError(f"project: K must be 3x3, got shape {K.shape}")
    p = np.asarray(pts_cam, dtype=np.float64).reshape(-1, 3)
    front = p[:, 2] > 0
    uv = np.full((len(p), 2), np.nan)
    z = p[front, 2]
    uv[front, 0] = K[0, 0] * p[front, 0] / z + K[0, 1] * p[front, 1] / z + K[0, 2]
    uv[front, 1] = K[1, 1] * p[front, 1] / z + K[1, 2]
    return uv, front


def backproject(depth: ArrayLike, intrinsics: Intrinsics, mask: ArrayLike | None = None) -> NDArray[np.float64]:
    """Back-project valid depth pixels (depth > 0, and inside ``mask``) to camera points.

    Args:
        depth: (H, W) depth along the optical axis (0 = invalid).
        intrinsics: camera intrinsics matching the image size.
        mask: optional (H, W) boolean mask of pixels to use.

    Returns: (N, 3) points in the camera (RDF) frame, in row-major pixel order.
    """
    d = np.asarray(depth)
    if d.shape != (intrinsics.height, intrinsics.width):
        raise ConfigError(
            f"backproject: depth shape {d.shape} does not match intrinsics {intrinsics.height}x{intrinsics.width}"
        )
    valid = np.isfinite(d) & (d > 0)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != d.shape:
            raise ConfigError(f"backproject: mask shape {m.shape} does not match depth shape {d.shape}")
        valid &= m
    v, u = np.nonzero(valid)
    z = d[v, u].astype(np.float64)
    x = (u - intrinsics.cx) * z / intrinsics.fx
    y = (v - intrinsics.cy) * z / intrinsics.fy
    return np.column_stack([x, y, z])


def backproject_pixels(uv: ArrayLike, z: ArrayLike, intrinsics: Intrinsics) -> NDArray[np.float64]:
    """Back-project pixels ``uv`` (N, 2) (column, row; any sub-pixel position) at depths ``z`` (N,).

    Same convention as ``backproject``: ``x = (u - cx) z / fx``, ``y = (v - cy) z / fy``.

    Returns: (N, 3) points in the camera (RDF) frame.
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    z = np.asarray(z, dtype=np.float64).reshape(-1)
    if len(z) != len(uv):
        raise ConfigError(f"backproject_pixels: {len(uv)} pixels but {len(z)} depths")
    x = (uv[:, 0] - intrinsics.cx) * z / intrinsics.fx
    y = (uv[:, 1] - intrinsics.cy) * z / intrinsics.fy
    return np.column_stack([x, y, z])
