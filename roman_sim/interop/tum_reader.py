"""Read a TUM RGB-D sequence folder (real or exported) as ``Frame`` objects.

What the mapper sees: depth (``depth.txt``), RGB (``rgb.txt``, optional), the odometry and
the camera. What only the evaluation sees, in ``frame.truth``: the true body pose (from
``groundtruth.txt``) and, when the folder has instance masks (``masks.txt``, as exported
sequences do), the true object ids; a real sequence has no masks, so ``object_ids`` is None.

Streams are associated by time stamp (``associate``) with ``max_time_diff_s``: the frame
time is the RGB stamp (the depth stamp without RGB); depth, masks, odometry and ground
truth are matched to it. Frames without depth or odometry are dropped, and so are frames
without a ground-truth pose when the folder has a ``groundtruth.txt`` (a map is built from
frames that all have truth, or none); the counts are logged.

An exported folder's ``camera.yaml`` names the epoch of its stamps (``time_epoch_ns``); the
reader takes it off every stamp it reads (lists exactly, trajectories to float precision), so
the frames of an export come back at their times since the robot's start.

Trajectory files are camera poses (TUM's convention); body poses are
``T_x_body = T_x_cam @ inv(T_body_cam)``. ``T_body_cam`` comes from the configuration,
else ``camera.yaml``, else the optical camera on a level body at its origin (``R_FLU_RDF``,
no offset): the gravity-aligned submaps then assume the trajectory frame has z up.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.geometry import R_FLU_RDF, inv_T, make_T
from roman_sim.core.registry import Registry
from roman_sim.core.seeding import child_rng
from roman_sim.core.sensors import Frame, FrameTruth, Intrinsics, check_intrinsics
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum
from roman_sim.interop.associate import associate, read_list
from roman_sim.interop.images import TUM_DEPTH_SCALE, mask_to_ids, read_png, units_to_depth
from roman_sim.interop.tum_camera import CameraFile, read_camera_file
from roman_sim.sim.odometry import DRIFT_PRESETS, DriftConfig, drift_trajectory, resolve_drift

log = logging.getLogger(__name__)


class IntrinsicsConfig(StrictModel):
    """Pinhole intrinsics in pixels (image size from the images when not given)."""

    fx: float = Field(..., gt=0)
    fy: float = Field(..., gt=0)
    cx: float
    cy: float
    width: int | None = Field(None, ge=1)
    height: int | None = Field(None, ge=1)


class TumSourceConfig(StrictModel):
    """A TUM RGB-D folder as a robot's sensor stream.

    ``odometry`` (what the mapper uses as ``T_odom_body``): ``auto`` = the folder's
    ``odometry.txt`` when present (exported sequences have one), else ``drift``;
    ``drift`` = the ground truth through the simulator's drift model ``drift`` (seeded by
    the seed and robot name, like a simulated robot); ``groundtruth`` = the true poses
    (no drift: for testing front end and alignment alone); anything else is a TUM file of
    camera poses (relative to the folder), e.g. your own VIO's output.
    """

    tum: Path
    depth_scale: float | None = Field(None, gt=0, description="depth units per metre (camera.yaml's, else 5000)")
    max_time_diff_s: float = Field(0.02, gt=0, le=1.0)
    intrinsics: IntrinsicsConfig | None = None
    T_body_cam: list[list[float]] | None = None
    odometry: str = Field("auto", min_length=1)
    drift: str | DriftConfig = "typical"
    masks: bool = Field(True, description="use masks/ (when present) as the frames' true object ids")
    objects: Path | None = Field(
        None,
        description="object table for the simulated encoder (default: objects.json "
        "in the folder or its parent, as an export lays them out)",
    )
    rgb: bool = True
    max_frames: int | None = Field(None, ge=1)

    @field_validator("T_body_cam")
    @classmethod
    def _is_4x4(cls, v: list[list[float]] | None) -> list[list[float]] | None:
        if v is not None and np.asarray(v, dtype=np.float64).shape != (4, 4):
            raise ValueError("must be a 4x4 matrix (list of 4 rows of 4 numbers)")
        return v

    @field_validator("drift")
    @classmethod
    def _known_preset(cls, v: str | DriftConfig) -> str | DriftConfig:
        if isinstance(v, str) and v not in DRIFT_PRESETS:
            raise ValueError(f"unknown drift preset {v!r} (valid: {', '.join(DRIFT_PRESETS.names())})")
        return v


#: Where the odometry comes from: name -> function(sequence) -> camera poses ``T_odom_cam``.
ODOMETRY_SOURCES: Registry[Callable[["TumSequence"], Trajectory]] = Registry("odometry source")


def _from_file(seq: TumSequence, name: str) -> Trajectory:
    path = seq.dir / name
    if not path.is_file():
        raise ConfigError(
            f"source.odometry: {path} not found (valid: {', '.join(ODOMETRY_SOURCES.names())}, "
            "or a TUM file of camera poses)"
        )
    return seq.since_epoch(read_tum(path))


def _needs_truth(seq: TumSequence, what: str) -> Trajectory:
    if seq.gt is None:
        raise ConfigError(f"{seq.dir}: odometry {what!r} needs groundtruth.txt (give odometry: <file>)")
    return seq.gt


def _groundtruth(seq: TumSequence) -> Trajectory:
    return _needs_truth(seq, "groundtruth")


def _drifted(seq: TumSequence) -> Trajectory:
    gt = _needs_truth(seq, "drift")
    T_wb = gt.T @ inv_T(seq.T_body_cam)
    T_ob = drift_trajectory(T_wb, resolve_drift(seq.cfg.drift), child_rng(seq.seed, "drift", seq.robot))
    return Trajectory(gt.t, T_ob @ seq.T_body_cam)


def _auto(seq: TumSequence) -> Trajectory:
    return _from_file(seq, "odometry.txt") if (seq.dir / "odometry.txt").is_file() else _drifted(seq)


for _name, _fn in (("auto", _auto), ("drift", _drifted), ("groundtruth", _groundtruth)):
    ODOMETRY_SOURCES.register(_name, _fn)


class TumSequence:
    """An associated TUM RGB-D folder as a ``FrameSource``; ``frames()`` streams it (one frame in memory at a time).

    Args:
        cfg: the source configuration.
        robot: robot name given to the frames.
        seed: seed of the drift model (odometry ``drift``).
    """

    def __init__(self, cfg: TumSourceConfig, robot: str = "robot", seed: int = 0) -> None:
        self.cfg, self.robot, self.seed = cfg, robot, int(seed)
        self.dir = Path(cfg.tum)
        if not self.dir.is_dir():
            raise ConfigError(f"source.tum {self.dir}: not a folder")
        self.camera_file = read_camera_file(self.dir)
        self.epoch_ns = self.camera_file.time_epoch_ns if self.camera_file is not None else 0
        self.T_body_cam = self._T_body_cam()
        self.depth_scale = float(
            cfg.depth_scale or (self.camera_file and self.camera_file.depth_scale) or TUM_DEPTH_SCALE
        )
        gt = self.dir / "groundtruth.txt"
        self.gt = self.since_epoch(read_tum(gt)) if gt.is_file() else None
        self._associate()
        self.intrinsics = self._intrinsics()

    def since_epoch(self, traj: Trajectory) -> Trajectory:
        """``traj`` with the folder's stamp epoch taken off its times."""
        return traj if not self.epoch_ns else Trajectory(traj.t - self.epoch_ns / 1e9, traj.T)

    def _T_body_cam(self) -> NDArray[np.float64]:
        if self.cfg.T_body_cam is not None:
            return np.asarray(self.cfg.T_body_cam, dtype=np.float64)
        if self.camera_file is not None and self.camera_file.T_body_cam is not None:
            return self.camera_file.T_body_cam
        return make_T(R_FLU_RDF)

    def _associate(self) -> None:
        tol = self.cfg.max_time_diff_s
        t_d, self._depth = read_list(self.dir / "depth.txt", self.epoch_ns)
        use_rgb = self.cfg.rgb and (self.dir / "rgb.txt").is_file()
        t_rgb, self._rgb = read_list(self.dir / "rgb.txt", self.epoch_ns) if use_rgb else (t_d, list(self._depth))
        ir, idp = associate(t_rgb, t_d, tol)
        t = t_rgb[ir]
        keep = np.ones(len(t), dtype=bool)
        odom = (
            ODOMETRY_SOURCES.get(self.cfg.odometry)(self)
            if self.cfg.odometry in ODOMETRY_SOURCES
            else _from_file(self, self.cfg.odometry)
        )
        T_odom = self._match(t, odom, keep)
        T_world = None if self.gt is None else self._match(t, self.gt, keep)
        masks: list[str | None] = [None] * len(t)
        if self.cfg.masks and (self.dir / "masks.txt").is_file():
            t_m, names = read_list(self.dir / "masks.txt", self.epoch_ns)
            im, jm = associate(t_d[idp], t_m, tol)
            for i, j in zip(im, jm):
                masks[i] = names[j]
            keep &= np.array([m is not None for m in masks])
        idx = np.flatnonzero(keep)[: self.cfg.max_frames]
        if len(idx) == 0:
            raise StorageError(f"{self.dir}: no frame has depth, odometry and truth within {tol} s of its RGB stamp")
        if len(idx) < len(t_rgb):
            log.warning("%s: %d of %d images kept after association", self.dir, len(idx), len(t_rgb))
        self.times = t[idx]
        self._files = [(self._rgb[ir[i]] if use_rgb else None, self._depth[idp[i]], masks[i]) for i in idx]
        self.T_odom_body = T_odom[idx] @ inv_T(self.T_body_cam)
        self.T_world_body = None if T_world is None else T_world[idx] @ inv_T(self.T_body_cam)
        self.has_masks = all(m is not None for _, _, m in self._files)

    def _match(self, t: NDArray[np.float64], traj: Trajectory, keep: NDArray[np.bool_]) -> NDArray[np.float64]:
        """Poses at the frame times (by association); frames without a match are unkept."""
        out = np.tile(np.eye(4), (len(t), 1, 1))
        i, j = associate(t, traj.t, self.cfg.max_time_diff_s)
        out[i] = traj.T[j]
        matched = np.zeros(len(t), dtype=bool)
        matched[i] = True
        keep &= matched
        return out

    def _intrinsics(self) -> Intrinsics:
        h, w = np.asarray(self._read(self._files[0][1])).shape[:2]
        c = self.cfg.intrinsics
        if c is not None:
            cam = CameraFile(c.fx, c.fy, c.cx, c.cy, c.width, c.height)
        elif self.camera_file is not None:
            cam = self.camera_file
        else:
            raise ConfigError(
                f"source.intrinsics: {self.dir} has no camera.yaml or camera.txt; give "
                "intrinsics: {fx, fy, cx, cy} (pixels)"
            )
        return check_intrinsics(cam.intrinsics(w, h))

    def _read(self, name: str) -> Any:
        return read_png(self.dir / name)

    @property
    def name(self) -> str:
        """The robot name given to the frames (``FrameSource``)."""
        return self.robot

    def __len__(self) -> int:
        return len(self.times)

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[Frame]:
        """The frames in time order (depth in metres, float32; 0 = invalid); only ``indices`` if given."""
        shape = (self.intrinsics.height, self.intrinsics.width)
        for k in range(len(self)) if indices is None else indices:
            rgb_name, depth_name, mask_name = self._files[k]
            units = self._read(depth_name)
            if units.dtype != np.uint16 or units.shape != shape:
                raise StorageError(f"{self.dir / depth_name}: expected a {shape[1]}x{shape[0]} 16-bit depth PNG")
            rgb = None
            if rgb_name is not None:
                rgb = self._read(rgb_name)
                if rgb.shape != (*shape, 3):
                    raise StorageError(f"{self.dir / rgb_name}: expected a {shape[1]}x{shape[0]} colour PNG")
            truth = None
            if self.T_world_body is not None:
                ids = None if mask_name is None else mask_to_ids(self._read(mask_name))
                truth = FrameTruth(ids, self.T_world_body[k])
            yield Frame(
                self.robot,
                k,
                float(self.times[k]),
                rgb,
                units_to_depth(units, self.depth_scale),
                self.T_odom_body[k],
                self.T_body_cam.copy(),
                self.intrinsics,
                truth=truth,
            )


def read_tum_sequence(path: str | Path, robot: str = "robot", seed: int = 0, **options: Any) -> TumSequence:
    """A TUM RGB-D folder as a ``TumSequence`` (options: the fields of ``TumSourceConfig``)."""
    from roman_sim.core.config import validate_model

    cfg = validate_model(TumSourceConfig, {"tum": str(path), **options}, source="source")
    return TumSequence(cfg, robot=robot, seed=seed)
