"""A robot's IMU and second camera in an export: topic names and Kalibr-style calibration files.

ROS 2 topics (``r`` is the robot name), added to a bag when the robot has the sensor:

=====================================  ============================  ==========================
topic                                  type                          content
=====================================  ============================  ==========================
``/r/imu``                             sensor_msgs/msg/Imu           gyroscope and accelerometer
                                                                     in ``r/imu_link`` (the body
                                                                     axes, FLU); no orientation
``/r/camera/right/image_raw``          sensor_msgs/msg/Image         the second camera, encoded
                                                                     as the first
``/r/camera/right/camera_info``        sensor_msgs/msg/CameraInfo    same intrinsics; ``P[3] =
                                                                     -fx * baseline`` (ROS's
                                                                     right-camera convention)
=====================================  ============================  ==========================

Calibration files in Kalibr's formats (``<robot>/kalibr/``):

- ``camchain.yaml``: ``cam0`` (the colour camera) and ``cam1`` (the second camera), each with
  ``camera_model: pinhole``, ``intrinsics: [fu, fv, pu, pv]``, ``distortion_model: radtan``
  and zero ``distortion_coeffs``, ``resolution: [width, height]``, ``rostopic``; ``cam1``
  has ``T_cn_cnm1`` (= ``T_c1_c0``, cam0 coordinates to cam1's); with an IMU each camera
  has ``T_cam_imu`` (IMU coordinates to the camera's; the IMU is the body frame, so it is
  ``inv(T_body_cam)``) and ``timeshift_cam_imu: 0.0``.
- ``imu.yaml`` (with an IMU): Kalibr's IMU file: ``accelerometer_noise_density``,
  ``accelerometer_random_walk``, ``gyroscope_noise_density``, ``gyroscope_random_walk``
  (continuous time, Kalibr's units), ``rostopic`` and ``update_rate``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml
from numpy.typing import NDArray

from roman_sim.core.atomic import write_text
from roman_sim.core.geometry import inv_T
from roman_sim.core.sensors import Intrinsics

if TYPE_CHECKING:
    from roman_sim.sim.imu import ImuData
    from roman_sim.sim.source import SensorRig

KALIBR_DIR = "kalibr"


def color_topic(robot: str) -> str:
    """The first (colour) camera's image topic."""
    return f"/{robot}/camera/color/image_raw"


def rig_topics(robot: str, imu: bool, stereo: bool) -> dict[str, str]:
    """Topic name -> message type of a robot's IMU and second camera (those it has)."""
    out = {}
    if stereo:
        out[f"/{robot}/camera/right/image_raw"] = "sensor_msgs/msg/Image"
        out[f"/{robot}/camera/right/camera_info"] = "sensor_msgs/msg/CameraInfo"
    if imu:
        out[f"/{robot}/imu"] = "sensor_msgs/msg/Imu"
    return out


def matrix_rows(T: NDArray[np.float64]) -> list[list[float]]:
    """A 4x4 matrix as rows of plain floats (rounded to 1e-12, no -0.0)."""
    return [[float(v) + 0.0 for v in row] for row in np.round(np.asarray(T, dtype=np.float64), 12)]


def _camera(intr: Intrinsics, topic: str) -> dict[str, Any]:
    return {
        "camera_model": "pinhole",
        "intrinsics": [float(intr.fx), float(intr.fy), float(intr.cx), float(intr.cy)],
        "distortion_model": "radtan",
        "distortion_coeffs": [0.0, 0.0, 0.0, 0.0],
        "resolution": [int(intr.width), int(intr.height)],
        "rostopic": topic,
    }


def camchain(robot: str, intr: Intrinsics, T_body_cam: NDArray[np.float64], rig: SensorRig) -> dict[str, Any]:
    """Kalibr's ``camchain.yaml`` of a robot's cameras (module docstring)."""
    cams = {"cam0": _camera(intr, color_topic(robot))}
    T_bc = np.asarray(T_body_cam, dtype=np.float64)
    mounts = {"cam0": T_bc}
    if rig.T_cam_cam2 is not None:
        cams["cam0"]["cam_overlaps"] = [1]
        cams["cam1"] = {
            **_camera(intr, f"/{robot}/camera/right/image_raw"),
            "cam_overlaps": [0],
            "T_cn_cnm1": matrix_rows(inv_T(rig.T_cam_cam2)),
        }
        mounts["cam1"] = T_bc @ rig.T_cam_cam2
    if rig.imu is not None:
        for name, T in mounts.items():
            cams[name]["T_cam_imu"] = matrix_rows(inv_T(T))
            cams[name]["timeshift_cam_imu"] = 0.0
    return cams


def kalibr_imu(robot: str, imu: ImuData) -> dict[str, Any]:
    """Kalibr's IMU file (module docstring)."""
    n = imu.noise
    return {
        "accelerometer_noise_density": float(n.accelerometer_noise_density),
        "accelerometer_random_walk": float(n.accelerometer_random_walk),
        "gyroscope_noise_density": float(n.gyroscope_noise_density),
        "gyroscope_random_walk": float(n.gyroscope_random_walk),
        "rostopic": f"/{robot}/imu",
        "update_rate": float(imu.rate_hz),
    }


class _FlowListDumper(yaml.SafeDumper):
    """Block mappings; lists of scalars on one line."""


def _list(dumper: yaml.SafeDumper, data: list[Any]) -> yaml.Node:
    flow = all(not isinstance(v, (list, dict)) for v in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


_FlowListDumper.add_representer(list, _list)


def dump_flow_lists(doc: dict[str, Any]) -> str:
    """YAML of ``doc`` in its key order, with lists of numbers on one line (as Kalibr and EuRoC write them)."""
    return yaml.dump(doc, Dumper=_FlowListDumper, sort_keys=False, default_flow_style=False, width=1000)


def write_kalibr(folder: Path, robot: str, intr: Intrinsics, T_body_cam: NDArray[np.float64], rig: SensorRig) -> None:
    """Write ``folder/kalibr/camchain.yaml`` and, with an IMU, ``imu.yaml``."""
    out = Path(folder) / KALIBR_DIR
    write_text(out / "camchain.yaml", dump_flow_lists(camchain(robot, intr, T_body_cam, rig)))
    if rig.imu is not None:
        write_text(out / "imu.yaml", dump_flow_lists(kalibr_imu(robot, rig.imu)))
