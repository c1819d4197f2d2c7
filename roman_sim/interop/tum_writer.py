"""One robot as a TUM RGB-D sequence folder, written frame by frame.

Layout (``<stamp>`` is ``<sec>.<nanosec>``, see ``roman_sim.interop.base``)::

    rgb/<stamp>.png        8-bit RGB
    depth/<stamp>.png      16-bit depth, ``depth_scale`` units per metre (5000), 0 = invalid
    masks/<stamp>.png      16-bit instance masks, object id + 1 (0 = background)
    rgb.txt depth.txt masks.txt   ``timestamp filename`` lists (3 comment lines first)
    associations.txt       ``t_rgb rgb/... t_depth depth/...`` (what associate.py prints)
    groundtruth.txt        true camera poses ``T_world_cam`` (TUM's convention: the optical
                           centre of the colour camera; RDF optical axes)
    odometry.txt           drifted camera poses ``T_odom_cam`` (the robot's VIO, same frame
                           convention, so evo compares it with groundtruth.txt directly)
    groundtruth_body.txt   true body poses ``T_world_body`` (FLU body)
    odometry_body.txt      drifted body poses ``T_odom_body``
    camera.yaml            intrinsics, depth scale, ``T_body_cam`` (camera in body)
    camera.txt             ``fx fy cx cy d0 d1 d2 d3 d4`` then ``width height``

Every file is written atomically; the lists and trajectories are written by ``close()``
(they are small: one line per frame), the images as the frames arrive.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.atomic import write_bytes, write_text
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSONLike
from roman_sim.core.sensors import Frame, Intrinsics
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import format_tum
from roman_sim.interop.base import EXPORT_EPOCH_NS, FORMATS, frame_time, stamp_ns, stamp_text
from roman_sim.interop.images import TUM_DEPTH_SCALE, depth_to_units, encode_png
from roman_sim.interop.masks import MaskWriter, list_text
from roman_sim.interop.tum_camera import CAMERA_TXT, CAMERA_YAML, camera_txt_text, camera_yaml_text

log = logging.getLogger(__name__)


def stamped_tum(ns: list[int], T: NDArray[np.float64]) -> str:
    """TUM lines of poses ``T`` (N, 4, 4) stamped with the exact text of the stamps ``ns``."""
    rows = format_tum(Trajectory(np.array([frame_time(n) for n in ns]), T)).splitlines()
    return "".join(f"{stamp_text(n)} {row.split(' ', 1)[1]}\n" for n, row in zip(ns, rows))


class TumWriter:
    """Writes one robot's frames as a TUM RGB-D folder (see the module docstring).

    Args:
        out_dir: the robot's folder (created).
        robot: robot name.
        intrinsics: camera intrinsics of every frame.
        T_body_cam: 4x4 camera pose in the body frame.
        depth_scale: depth units per metre in the depth PNGs.
    """

    def __init__(
        self,
        out_dir: Path,
        robot: str,
        intrinsics: Intrinsics,
        T_body_cam: NDArray[np.float64],
        depth_scale: float = TUM_DEPTH_SCALE,
    ) -> None:
        if not np.isfinite(depth_scale) or depth_scale <= 0:
            raise StorageError(f"depth_scale must be a positive number of units per metre, got {depth_scale}")
        self.dir = Path(out_dir)
        self.robot, self.intr, self.scale = robot, intrinsics, float(depth_scale)
        self.T_bc = np.asarray(T_body_cam, dtype=np.float64)
        for sub in ("rgb", "depth"):
            (self.dir / sub).mkdir(parents=True, exist_ok=True)
        self._masks = MaskWriter(self.dir, robot)
        self._stamps: list[str] = []
        self._ns: list[int] = []
        self._T_wb: list[NDArray[np.float64]] = []
        self._T_ob: list[NDArray[np.float64]] = []
        self._too_deep = 0

    def write(self, frame: Frame) -> None:
        """Write the frame's three PNGs and remember its poses."""
        if frame.rgb is None or frame.truth is None or frame.truth.object_ids is None:
            raise StorageError(
                f"TUM export: frame {frame.index} of robot {frame.robot} needs RGB, instance ids and the true pose"
            )
        if frame.intrinsics != self.intr or not np.allclose(frame.T_body_cam, self.T_bc):
            raise StorageError(f"TUM export: frame {frame.index}: camera differs from the sequence's")
        ns = stamp_ns(frame.t)
        s = stamp_text(ns)
        if self._ns and ns <= self._ns[-1]:
            raise StorageError(f"TUM export: frame {frame.index}: time stamp {s} does not increase")
        units, too_deep = depth_to_units(frame.depth, self.scale)
        self._too_deep += too_deep
        write_bytes(self.dir / "rgb" / f"{s}.png", encode_png(np.asarray(frame.rgb, dtype=np.uint8)))
        write_bytes(self.dir / "depth" / f"{s}.png", encode_png(units))
        self._masks.write(frame, s)
        self._stamps.append(s)
        self._ns.append(ns)
        self._T_wb.append(np.asarray(frame.truth.T_world_body, dtype=np.float64))
        self._T_ob.append(np.asarray(frame.T_odom_body, dtype=np.float64))

    def close(self) -> dict[str, JSONLike]:
        """Write the lists, trajectories and camera files; returns counts."""
        if not self._stamps:
            raise StorageError(f"TUM export: robot {self.robot} has no frames")
        d, st = self.dir, self._stamps
        for kind, sub in (("color", "rgb"), ("depth", "depth")):
            write_text(d / f"{sub}.txt", list_text(kind, self.robot, [(s, f"{sub}/{s}.png") for s in st]))
        self._masks.close()
        write_text(d / "associations.txt", "".join(f"{s} rgb/{s}.png {s} depth/{s}.png\n" for s in st))
        T_wb, T_ob = np.stack(self._T_wb), np.stack(self._T_ob)
        for name, what, T in (
            ("groundtruth.txt", "true camera pose T_world_cam", T_wb @ self.T_bc),
            ("odometry.txt", "drifted camera odometry T_odom_cam", T_ob @ self.T_bc),
            ("groundtruth_body.txt", "true body pose T_world_body", T_wb),
            ("odometry_body.txt", "drifted body odometry T_odom_body", T_ob),
        ):
            head = f"# {what} of robot {self.robot}: timestamp tx ty tz qx qy qz qw\n"
            write_text(d / name, head + stamped_tum(self._ns, T))
        write_text(d / CAMERA_YAML, camera_yaml_text(self.intr, self.T_bc, self.scale, self.robot, EXPORT_EPOCH_NS))
        write_text(d / CAMERA_TXT, camera_txt_text(self.intr, self.robot))
        if self._too_deep:
            log.warning(
                "robot %s: %d depth readings deeper than %.3f m stored as invalid (16-bit limit)",
                self.robot,
                self._too_deep,
                65535 / self.scale,
            )
        return {"frames": len(st), "depth_dropped_too_deep": self._too_deep, "folder": str(d)}

    def abort(self) -> None:
        """Nothing to undo: every image already written is complete (atomic)."""


FORMATS.register("tum", TumWriter)
