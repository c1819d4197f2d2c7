"""One robot as an EuRoC MAV (ASL) folder, the layout VIO systems read (``--format euroc``).

Layout of ``<robot>/`` (``<ns>``: the stamp in integer nanoseconds, ``roman_sim.interop.base``)::

    mav0/cam0/data/<ns>.png         8-bit grey images of the colour camera (OpenCV's
    mav0/cam0/data.csv              RGB -> grey); ``#timestamp [ns],filename``
    mav0/cam0/sensor.yaml           EuRoC's camera file: T_BS (camera in body), rate_hz,
                                    resolution, pinhole intrinsics [fu, fv, cu, cv], zero
                                    radial-tangential distortion
    mav0/cam1/...                   the second camera (``stereo``), the same files
    mav0/imu0/data.csv              ``#timestamp [ns],w_RS_S_x [rad s^-1],...,a_RS_S_z [m s^-2]``
    mav0/imu0/sensor.yaml           T_BS (identity: the IMU is the body frame), rate_hz and the
                                    noise densities and random walks
    mav0/state_groundtruth_estimate0/data.csv
                                    ``#timestamp, p_RS_R_x [m], ..., q_RS_w [], ..., v_RS_R_x
                                    [m s^-1], ..., b_w_RS_S_x [rad s^-1], ..., b_a_RS_S_z
                                    [m s^-2]``: the true body (IMU) pose, velocity and biases,
                                    at the IMU's times (at the frames' without an IMU)
    kalibr/camchain.yaml, imu.yaml  Kalibr-style calibration (``roman_sim.interop.rig``)
    masks/<stamp>.png, masks.txt    instance masks, as every export writes them

The camera and IMU folders exist only when the robot has them (``RobotConfig.stereo``,
``imu``). The ground truth's pose and velocity come from the continuous trajectory the IMU
is consistent with (``roman_sim.sim.imu.SmoothTrajectory``), which passes through every
frame pose. Images are written as the frames arrive, the tables and YAML files when the
writer closes; every file atomically.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_bytes, write_text
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSONLike
from roman_sim.core.sensors import Frame, Intrinsics
from roman_sim.interop.base import FORMATS, frame_time, stamp_ns, stamp_text
from roman_sim.interop.images import encode_png
from roman_sim.interop.masks import MaskWriter
from roman_sim.interop.rig import dump_flow_lists, write_kalibr
from roman_sim.sim.source import SensorRig

log = logging.getLogger(__name__)

MAV = "mav0"
IMU_HEADER = (
    "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
    "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]"
)
GROUNDTRUTH_HEADER = (
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
    "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], "
    "b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], "
    "b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]"
)


def _T_BS(T: NDArray[np.float64]) -> dict[str, Any]:
    """EuRoC's matrix block: ``cols``, ``rows`` and the row-major ``data``."""
    data = [float(v) + 0.0 for v in np.round(np.asarray(T, dtype=np.float64), 12).reshape(-1)]
    return {"cols": 4, "rows": 4, "data": data}


def camera_sensor_yaml(name: str, intr: Intrinsics, T_body_cam: NDArray[np.float64], rate_hz: float) -> str:
    """A camera's ``sensor.yaml`` in EuRoC's layout."""
    doc = {
        "sensor_type": "camera",
        "comment": f"roman_sim {name}, rendered pinhole camera",
        "T_BS": _T_BS(T_body_cam),
        "rate_hz": float(rate_hz),
        "resolution": [int(intr.width), int(intr.height)],
        "camera_model": "pinhole",
        "intrinsics": [float(intr.fx), float(intr.fy), float(intr.cx), float(intr.cy)],
        "distortion_model": "radial-tangential",
        "distortion_coefficients": [0.0, 0.0, 0.0, 0.0],
    }
    return "# General sensor definitions.\n" + dump_flow_lists(doc)


def imu_sensor_yaml(rig: SensorRig) -> str:
    """The IMU's ``sensor.yaml`` in EuRoC's layout (its noise in Kalibr's units)."""
    imu = rig.imu
    assert imu is not None
    n = imu.noise
    doc = {
        "sensor_type": "imu",
        "comment": f"roman_sim IMU, {n.device or 'custom noise'}" + ("" if imu.noisy else ", readings noise-free"),
        "T_BS": _T_BS(np.eye(4)),
        "rate_hz": float(imu.rate_hz),
        "gyroscope_noise_density": float(n.gyroscope_noise_density),
        "gyroscope_random_walk": float(n.gyroscope_random_walk),
        "accelerometer_noise_density": float(n.accelerometer_noise_density),
        "accelerometer_random_walk": float(n.accelerometer_random_walk),
    }
    return "# General sensor definitions.\n" + dump_flow_lists(doc)


def _rows(ns: list[int], values: NDArray[np.float64]) -> str:
    return "".join(f"{n}," + ",".join(repr(float(v)) for v in row) + "\n" for n, row in zip(ns, values))


class EurocWriter:
    """Writes one robot's frames as an EuRoC MAV folder (module docstring).

    Args:
        out_dir: the robot's folder (created).
        robot: robot name.
        intrinsics: camera intrinsics of every frame.
        T_body_cam: 4x4 camera pose in the body frame.
    """

    def __init__(self, out_dir: Path, robot: str, intrinsics: Intrinsics, T_body_cam: NDArray[np.float64]) -> None:
        self.dir, self.robot, self.intr = Path(out_dir), robot, intrinsics
        self.T_bc = np.asarray(T_body_cam, dtype=np.float64)
        self.mav = self.dir / MAV
        self._rig: SensorRig | None = None
        self._masks = MaskWriter(self.dir, robot)
        self._ns: list[int] = []
        self._T_wb: list[NDArray[np.float64]] = []

    def set_rig(self, rig: SensorRig) -> None:
        """The robot's continuous trajectory, IMU and second camera (before the first frame)."""
        if self._ns:
            raise StorageError(f"EuRoC export: robot {self.robot}: sensors added after the first frame")
        self._rig = rig

    @property
    def _stereo(self) -> bool:
        return self._rig is not None and self._rig.T_cam_cam2 is not None

    def write(self, frame: Frame) -> None:
        """Write the frame's grey image(s) and mask; remember its stamp and true pose."""
        if frame.rgb is None or frame.truth is None:
            raise StorageError(f"EuRoC export: frame {frame.index} of robot {frame.robot} needs RGB and truth")
        if self._stereo and frame.rgb_right is None:
            raise StorageError(f"EuRoC export: frame {frame.index} of robot {frame.robot} has no second image")
        ns = stamp_ns(frame.t)
        if self._ns and ns <= self._ns[-1]:
            raise StorageError(f"EuRoC export: frame {frame.index}: time stamp does not increase")
        images = [("cam0", frame.rgb)] + ([("cam1", frame.rgb_right)] if self._stereo else [])
        for cam, rgb in images:
            import cv2  # on first use: importing OpenCV maps hundreds of MB (a capped run would fail here)

            grey = cv2.cvtColor(np.ascontiguousarray(rgb, dtype=np.uint8), cv2.COLOR_RGB2GRAY)
            write_bytes(self.mav / cam / "data" / f"{ns}.png", encode_png(np.asarray(grey, dtype=np.uint8)))
        self._masks.write(frame, stamp_text(ns))
        self._ns.append(ns)
        self._T_wb.append(np.asarray(frame.truth.T_world_body, dtype=np.float64))

    def _camera_files(self, rate_hz: float) -> None:
        table = "#timestamp [ns],filename\n" + "".join(f"{n},{n}.png\n" for n in self._ns)
        mounts = [("cam0", self.T_bc)]
        if self._stereo:
            assert self._rig is not None and self._rig.T_cam_cam2 is not None
            mounts.append(("cam1", self.T_bc @ self._rig.T_cam_cam2))
        for cam, T in mounts:
            write_text(self.mav / cam / "data.csv", table)
            write_text(self.mav / cam / "sensor.yaml", camera_sensor_yaml(cam, self.intr, T, rate_hz))

    def _groundtruth(self) -> tuple[list[int], NDArray[np.float64]]:
        """Stamps and rows (p, q wxyz, v, b_w, b_a) of the true state."""
        rig, frames_ns = self._rig, self._ns
        traj = None if rig is None else rig.trajectory
        if rig is not None and rig.imu is not None:
            t = rig.imu.t
            ns = [stamp_ns(x) for x in t]
            bw, ba = rig.imu.gyro_bias, rig.imu.accel_bias
        else:
            t = np.array([frame_time(n) for n in frames_ns])
            ns, bw, ba = list(frames_ns), np.zeros((len(t), 3)), np.zeros((len(t), 3))
        if traj is not None:
            T, v = traj.poses(t), traj.velocity(t)
        else:  # one frame, or a source without a continuous trajectory: at rest
            T, v = np.stack(self._T_wb), np.zeros((len(t), 3))
        q = Rotation.from_matrix(T[:, :3, :3]).as_quat()[:, [3, 0, 1, 2]]
        return ns, np.column_stack([T[:, :3, 3], q, v, bw, ba])

    def close(self) -> dict[str, JSONLike]:
        """Write the tables, sensor files and calibration; returns counts."""
        if not self._ns:
            raise StorageError(f"EuRoC export: robot {self.robot} has no frames")
        rate = round(1e9 / float(np.median(np.diff(self._ns))), 6) if len(self._ns) > 1 else 0.0
        self._camera_files(rate)
        rig = self._rig
        if rig is not None and rig.imu is not None:
            imu = rig.imu
            ns = [stamp_ns(x) for x in imu.t]
            body = _rows(ns, np.column_stack([imu.gyro, imu.accel]))
            write_text(self.mav / "imu0" / "data.csv", IMU_HEADER + "\n" + body)
            write_text(self.mav / "imu0" / "sensor.yaml", imu_sensor_yaml(rig))
        gt_ns, gt = self._groundtruth()
        write_text(self.mav / "state_groundtruth_estimate0" / "data.csv", GROUNDTRUTH_HEADER + "\n" + _rows(gt_ns, gt))
        write_kalibr(self.dir, self.robot, self.intr, self.T_bc, rig or SensorRig(None))
        self._masks.close()
        return {
            "frames": len(self._ns),
            "cameras": 2 if self._stereo else 1,
            "imu_samples": 0 if rig is None or rig.imu is None else len(rig.imu.t),
            "folder": str(self.dir),
        }

    def abort(self) -> None:
        """Nothing to undo: every file already written is complete (atomic)."""


FORMATS.register("euroc", EurocWriter)
