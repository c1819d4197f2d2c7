"""Camera files of a TUM RGB-D folder: ``camera.yaml`` (written and read) and ``camera.txt``.

``camera.yaml`` holds the intrinsics (pixels, OpenCV convention: pixel centres at integer
coordinates), the depth scale, the camera mount ``T_body_cam`` and, in an export, the epoch
of its stamps (``time_epoch_ns``: the reader takes it off, so frame times count from the start). ``camera.txt`` is the
plain form a user can write by hand for a real sequence: a first line ``fx fy cx cy``
(optionally followed by the five distortion coefficients of TUM's calibration tables, which
must be zero: frames here are undistorted) and an optional second line ``width height``;
``#`` starts a comment.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from numpy.typing import NDArray

from roman_sim.core.errors import StorageError
from roman_sim.core.sensors import Intrinsics

CAMERA_YAML = "camera.yaml"
CAMERA_TXT = "camera.txt"
CAMERA_FORMAT = "roman_sim.tum_camera"


@dataclass
class CameraFile:
    """What a folder's camera file says (fields it does not give are None)."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int | None = None
    height: int | None = None
    depth_scale: float | None = None
    T_body_cam: NDArray[np.float64] | None = None
    time_epoch_ns: int = 0

    def intrinsics(self, width: int, height: int) -> Intrinsics:
        """Intrinsics for an image of ``width`` x ``height`` (checked against the file's size)."""
        if (self.width, self.height) != (None, None) and (self.width, self.height) != (width, height):
            raise StorageError(
                f"camera file: size {self.width}x{self.height} does not match the images ({width}x{height})"
            )
        return Intrinsics(width, height, self.fx, self.fy, self.cx, self.cy)


def camera_yaml_text(
    intr: Intrinsics, T_body_cam: NDArray[np.float64], depth_scale: float, robot: str, time_epoch_ns: int = 0
) -> str:
    """``camera.yaml``: intrinsics, depth scale, camera mount and stamp epoch of an exported sequence."""
    doc = {
        "format": CAMERA_FORMAT,
        "version": 1,
        "robot": robot,
        "width": intr.width,
        "height": intr.height,
        "fx": float(intr.fx),
        "fy": float(intr.fy),
        "cx": float(intr.cx),
        "cy": float(intr.cy),
        "distortion_model": "plumb_bob",
        "distortion": [0.0] * 5,
        "depth_scale": float(depth_scale),
        "depth_registered_to_rgb": True,
        "T_body_cam": np.round(np.asarray(T_body_cam, dtype=np.float64), 12).tolist(),
        "time_epoch_ns": int(time_epoch_ns),
        "frames": {
            "camera": "RDF optical (x right, y down, z forward)",
            "body": "FLU (x forward, y left, z up)",
            "groundtruth.txt": "T_world_cam",
            "odometry.txt": "T_odom_cam",
            "groundtruth_body.txt": "T_world_body",
            "odometry_body.txt": "T_odom_body",
        },
    }
    return yaml.safe_dump(doc, sort_keys=False)


def camera_txt_text(intr: Intrinsics, robot: str) -> str:
    """``camera.txt``: ``fx fy cx cy d0..d4`` (TUM's calibration order), then ``width height``."""
    return (
        f"# pinhole camera of robot {robot}: fx fy cx cy d0 d1 d2 d3 d4 (pixels, no distortion), "
        "then width height\n"
        f"{intr.fx:.9f} {intr.fy:.9f} {intr.cx:.9f} {intr.cy:.9f} 0 0 0 0 0\n{intr.width} {intr.height}\n"
    )


def _read_yaml(p: Path) -> CameraFile:
    try:
        doc = yaml.safe_load(p.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as err:
        raise StorageError(f"{p}: not a readable camera file ({type(err).__name__})") from None
    if not isinstance(doc, dict):
        raise StorageError(f"{p}: not a camera file (expected a mapping with fx, fy, cx, cy)")
    try:
        T = doc.get("T_body_cam")
        T_bc = None if T is None else np.asarray(T, dtype=np.float64).reshape(4, 4)
        scale = doc.get("depth_scale")
        return CameraFile(
            float(doc["fx"]),
            float(doc["fy"]),
            float(doc["cx"]),
            float(doc["cy"]),
            int(doc["width"]) if "width" in doc else None,
            int(doc["height"]) if "height" in doc else None,
            None if scale is None else float(scale),
            T_bc,
            int(doc.get("time_epoch_ns") or 0),
        )
    except (KeyError, TypeError, ValueError) as err:
        raise StorageError(
            f"{p}: not a readable camera file (needs fx, fy, cx, cy; {type(err).__name__}: {err})"
        ) from None


def _read_txt(p: Path) -> CameraFile:
    rows = []
    for line in p.read_text(encoding="utf-8").splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            try:
                rows.append([float(v) for v in line.split()])
            except ValueError:
                raise StorageError(f"{p}: not a number in {line!r}") from None
    if not rows or len(rows[0]) not in (4, 9) or (len(rows) > 1 and len(rows[1]) != 2):
        raise StorageError(f"{p}: expected a line 'fx fy cx cy [d0 d1 d2 d3 d4]' and optionally 'width height'")
    if any(d != 0 for d in rows[0][4:]):
        raise StorageError(f"{p}: distortion coefficients must be 0 (undistort the images first)")
    size = (int(rows[1][0]), int(rows[1][1])) if len(rows) > 1 else (None, None)
    fx, fy, cx, cy = rows[0][:4]
    return CameraFile(fx, fy, cx, cy, width=size[0], height=size[1])


def read_camera_file(folder: str | Path) -> CameraFile | None:
    """The folder's ``camera.yaml`` (preferred) or ``camera.txt``, or None when it has neither."""
    d = Path(folder)
    if (d / CAMERA_YAML).is_file():
        return _read_yaml(d / CAMERA_YAML)
    if (d / CAMERA_TXT).is_file():
        return _read_txt(d / CAMERA_TXT)
    return None
