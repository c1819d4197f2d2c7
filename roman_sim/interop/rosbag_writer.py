"""One robot as a ROS 2 bag (``rosbags``, pure Python), written frame by frame.

Topics (``r`` is the robot name; stamps are the frame times, see ``roman_sim.interop.base``):

=====================================  ============================  =======================
topic                                  type                          content
=====================================  ============================  =======================
``/r/camera/color/image_raw``          sensor_msgs/msg/Image         ``rgb8``
``/r/camera/color/camera_info``        sensor_msgs/msg/CameraInfo    pinhole, no distortion
``/r/camera/depth/image``              sensor_msgs/msg/Image         ``32FC1`` metres, NaN =
                                                                     no reading (REP 118),
                                                                     registered to colour
``/r/camera/depth/camera_info``        sensor_msgs/msg/CameraInfo    same camera
``/r/odom``                            nav_msgs/msg/Odometry         drifted odometry
``/tf``                                tf2_msgs/msg/TFMessage        ``world -> r/base_link_gt``
                                                                     (truth) and
                                                                     ``r/odom -> r/base_link``
``/tf_static``                         tf2_msgs/msg/TFMessage        ``r/base_link ->
                                                                     r/camera_optical_frame``
=====================================  ============================  =======================

A robot with an IMU or a second camera (``RobotConfig.imu``, ``stereo``) also has their
topics (``roman_sim.interop.rig``: ``/r/imu`` at the IMU rate, written in time order between
the frames; ``/r/camera/right/...``), their mounts in ``/tf_static`` (``r/imu_link``,
``r/camera_right_optical_frame``) and Kalibr-style calibration files in ``r/kalibr/``.

Images carry ``frame_id = r/camera_optical_frame`` (RDF optical axes); the body frames are
FLU. The truth lives in its own frame ``r/base_link_gt`` under ``world``, so it never
conflicts with the odometry tree (``r/odom -> r/base_link``) a SLAM system builds on.
``/tf_static`` is offered with transient-local durability, as ``robot_state_publisher``
does. The odometry twist is the finite difference of consecutive odometry poses in the
body frame (zero for the first frame); its covariances are zero ("unknown").

The bag is written into a temporary folder next to its destination and renamed when closed,
so an interrupted export never leaves a half bag under the final name.
"""

from __future__ import annotations

import logging
import os
import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.sensors import Frame, Intrinsics
from roman_sim.interop.base import FORMATS, stamp_ns, stamp_text
from roman_sim.interop.masks import MaskWriter
from roman_sim.interop.rig import color_topic, rig_topics, write_kalibr

if TYPE_CHECKING:
    from rosbags.interfaces import Qos
    from rosbags.typesys.store import Msg, Typestore

    from roman_sim.core.jsontypes import JSONLike
    from roman_sim.sim.source import SensorRig

log = logging.getLogger(__name__)

BAG_DIR = "bag"
STORAGES = ("mcap", "sqlite3")
#: rosbag2 metadata version: 8 keeps the QoS profiles as the YAML string ROS 2 Humble parses
#: (version 9 writes them as a list, which Humble's reader rejects); Iron and newer read 8 too.
METADATA_VERSION: Literal[8] = 8


def topics(robot: str) -> dict[str, str]:
    """Topic name -> message type of one robot's bag."""
    return {
        color_topic(robot): "sensor_msgs/msg/Image",
        f"/{robot}/camera/color/camera_info": "sensor_msgs/msg/CameraInfo",
        f"/{robot}/camera/depth/image": "sensor_msgs/msg/Image",
        f"/{robot}/camera/depth/camera_info": "sensor_msgs/msg/CameraInfo",
        f"/{robot}/odom": "nav_msgs/msg/Odometry",
        "/tf": "tf2_msgs/msg/TFMessage",
        "/tf_static": "tf2_msgs/msg/TFMessage",
    }


def _qos(transient_local: bool) -> Qos:
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    zero = QosTime(0, 0)
    return Qos(
        QosHistory.KEEP_LAST,
        1 if transient_local else 10,
        QosReliability.RELIABLE,
        QosDurability.TRANSIENT_LOCAL if transient_local else QosDurability.VOLATILE,
        zero,
        zero,
        QosLiveliness.AUTOMATIC,
        zero,
        False,
    )


class _Messages:
    """Builds the message objects of one robot with a ``rosbags`` type store."""

    def __init__(self, typestore: Typestore, robot: str, intr: Intrinsics) -> None:
        self.ts, self.t = typestore, typestore.types
        self.robot, self.intr = robot, intr
        self.cam_frame = f"{robot}/camera_optical_frame"

    def header(self, ns: int, frame_id: str) -> Msg:
        stamp = self.t["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return self.t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)

    def image(self, ns: int, data: NDArray[np.generic], encoding: str, frame_id: str | None = None) -> Msg:
        h, w = data.shape[:2]
        raw = np.ascontiguousarray(data).view(np.uint8).reshape(-1)
        return self.t["sensor_msgs/msg/Image"](
            header=self.header(ns, frame_id or self.cam_frame),
            height=h,
            width=w,
            encoding=encoding,
            is_bigendian=0,
            step=len(raw) // h,
            data=raw,
        )

    def camera_info(self, ns: int, frame_id: str | None = None, Tx: float = 0.0) -> Msg:
        k = self.intr
        K = np.array([k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1], dtype=np.float64)
        P = np.array([k.fx, 0, k.cx, Tx, 0, k.fy, k.cy, 0, 0, 0, 1, 0], dtype=np.float64)
        roi = self.t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        return self.t["sensor_msgs/msg/CameraInfo"](
            header=self.header(ns, frame_id or self.cam_frame),
            height=k.height,
            width=k.width,
            distortion_model="plumb_bob",
            d=np.zeros(5),
            k=K,
            r=np.eye(3).reshape(-1),
            p=P,
            binning_x=0,
            binning_y=0,
            roi=roi,
        )

    def _pose_parts(self, T: NDArray[np.float64]) -> tuple[Msg, Msg]:
        g = self.t
        q = Rotation.from_matrix(T[:3, :3]).as_quat()
        vec = g["geometry_msgs/msg/Vector3"](x=float(T[0, 3]), y=float(T[1, 3]), z=float(T[2, 3]))
        quat = g["geometry_msgs/msg/Quaternion"](x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))
        return vec, quat

    def transform(self, ns: int, parent: str, child: str, T: NDArray[np.float64]) -> Msg:
        vec, quat = self._pose_parts(T)
        tf = self.t["geometry_msgs/msg/Transform"](translation=vec, rotation=quat)
        return self.t["geometry_msgs/msg/TransformStamped"](
            header=self.header(ns, parent), child_frame_id=child, transform=tf
        )

    def imu(self, ns: int, gyro: NDArray[np.float64], accel: NDArray[np.float64], var: tuple[float, float]) -> Msg:
        """An Imu message without orientation (``orientation_covariance[0] = -1``); ``var`` is the
        (gyroscope, accelerometer) variance of one reading."""
        V3 = self.t["geometry_msgs/msg/Vector3"]
        unknown = np.zeros(9)
        unknown[0] = -1.0
        return self.t["sensor_msgs/msg/Imu"](
            header=self.header(ns, f"{self.robot}/imu_link"),
            orientation=self.t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=unknown,
            angular_velocity=V3(x=float(gyro[0]), y=float(gyro[1]), z=float(gyro[2])),
            angular_velocity_covariance=np.diag(np.full(3, var[0])).reshape(-1),
            linear_acceleration=V3(x=float(accel[0]), y=float(accel[1]), z=float(accel[2])),
            linear_acceleration_covariance=np.diag(np.full(3, var[1])).reshape(-1),
        )

    def tf(self, transforms: list[Msg]) -> Msg:
        return self.t["tf2_msgs/msg/TFMessage"](transforms=transforms)

    def odometry(
        self,
        ns: int,
        T: NDArray[np.float64],
        v_body: NDArray[np.float64],
        w_body: NDArray[np.float64],
        frame_id: str | None = None,
        child: str | None = None,
    ) -> Msg:
        g = self.t
        _, quat = self._pose_parts(T)
        pose = g["geometry_msgs/msg/Pose"](
            position=g["geometry_msgs/msg/Point"](x=float(T[0, 3]), y=float(T[1, 3]), z=float(T[2, 3])),
            orientation=quat,
        )
        V3 = g["geometry_msgs/msg/Vector3"]
        twist = g["geometry_msgs/msg/Twist"](
            linear=V3(x=float(v_body[0]), y=float(v_body[1]), z=float(v_body[2])),
            angular=V3(x=float(w_body[0]), y=float(w_body[1]), z=float(w_body[2])),
        )
        return g["nav_msgs/msg/Odometry"](
            header=self.header(ns, frame_id or f"{self.robot}/odom"),
            child_frame_id=child or f"{self.robot}/base_link",
            pose=g["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
            twist=g["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
        )


def body_twist(T_prev: NDArray[np.float64] | None, T: NDArray[np.float64], dt: float) -> tuple[NDArray, NDArray]:
    """Linear and angular body-frame velocity from two consecutive poses (zeros without a previous one)."""
    if T_prev is None or dt <= 0:
        return np.zeros(3), np.zeros(3)
    d = np.linalg.inv(T_prev) @ T
    return d[:3, 3] / dt, Rotation.from_matrix(d[:3, :3]).as_rotvec() / dt


class RosbagWriter:
    """Writes one robot's frames as a ROS 2 bag in ``out_dir/bag`` plus mask side files.

    Args:
        out_dir: the robot's folder (created); the bag goes to ``out_dir/bag``.
        robot: robot name (topic and frame prefix).
        intrinsics: camera intrinsics of every frame.
        T_body_cam: 4x4 camera pose in the body frame (the static transform).
        storage: ``mcap`` (ROS 2 Iron and later) or ``sqlite3`` (Humble's default); None:
            ``default_storage``.
        distro: ``rosbags`` type store for the message definitions.
    """

    #: Storage when none is given.
    default_storage = "mcap"
    #: Encoding of the colour images (``rgb8``, or ``bgr8``: OpenCV's order).
    color_encoding = "rgb8"

    def __init__(
        self,
        out_dir: Path,
        robot: str,
        intrinsics: Intrinsics,
        T_body_cam: NDArray[np.float64],
        storage: str | None = None,
        distro: str = "ros2_humble",
    ) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        storage = storage or self.default_storage
        from rosbags.typesys import Stores, get_typestore

        if storage not in STORAGES:
            raise ConfigError(f"storage: unknown {storage!r} (valid: {', '.join(STORAGES)})")
        try:
            typestore = get_typestore(Stores(distro))
        except ValueError:
            raise ConfigError(f"distro: unknown {distro!r} (valid: {', '.join(s.value for s in Stores)})") from None
        self.dir, self.robot, self.intr = Path(out_dir), robot, intrinsics
        self.T_bc = np.asarray(T_body_cam, dtype=np.float64)
        self.final = self.dir / BAG_DIR
        if self.final.exists():
            raise StorageError(f"{self.final}: already exists (remove it or export to a new folder)")
        self.dir.mkdir(parents=True, exist_ok=True)
        self._tmp_parent = Path(tempfile.mkdtemp(prefix=".bag.", suffix=".tmp", dir=self.dir))
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self._writer = Writer(self._tmp_parent / BAG_DIR, version=METADATA_VERSION, storage_plugin=plugin)
        self._writer.open()
        self._msgs = _Messages(typestore, robot, intrinsics)
        self._conn: dict[str, Any] = {}
        self._counts: dict[str, int] = {}
        self._add_topics(self.topic_table(robot))
        self._masks = MaskWriter(self.dir, robot)
        self._prev: tuple[int, NDArray[np.float64]] | None = None
        self._rig: SensorRig | None = None
        self._imu_next = 0

    def _add_topics(self, table: dict[str, str]) -> None:
        for topic, msgtype in table.items():
            qos = [_qos(topic == "/tf_static")]
            self._conn[topic] = self._writer.add_connection(
                topic, msgtype, typestore=self._msgs.ts, offered_qos_profiles=qos
            )
            self._counts[topic] = 0

    def set_rig(self, rig: SensorRig) -> None:
        """Also write the robot's IMU and second camera (``roman_sim.interop.rig``); before the first frame."""
        if self._prev is not None:
            raise StorageError(f"rosbag2 export: robot {self.robot}: sensors added after the first frame")
        self._rig = rig
        self._add_topics(rig_topics(self.robot, rig.imu is not None, rig.T_cam_cam2 is not None))

    def _color(self, ns: int, rgb: NDArray[np.uint8], frame_id: str | None = None) -> Msg:
        """A colour image message in ``color_encoding``."""
        image = np.asarray(rgb, dtype=np.uint8)
        if self.color_encoding == "bgr8":
            image = np.ascontiguousarray(image[..., ::-1])
        return self._msgs.image(ns, image, self.color_encoding, frame_id)

    def _static(self, ns: int) -> Msg:
        """``/tf_static``: the camera mount, and the IMU's and the second camera's when present."""
        m, r = self._msgs, self.robot
        transforms = [m.transform(ns, f"{r}/base_link", m.cam_frame, self.T_bc)]
        if self._rig is not None and self._rig.T_cam_cam2 is not None:
            T = self.T_bc @ self._rig.T_cam_cam2
            transforms.append(m.transform(ns, f"{r}/base_link", f"{r}/camera_right_optical_frame", T))
        if self._rig is not None and self._rig.imu is not None:
            transforms.append(m.transform(ns, f"{r}/base_link", f"{r}/imu_link", np.eye(4)))
        return m.tf(transforms)

    def _write_imu(self, until_ns: int | None) -> None:
        """The IMU readings stamped up to ``until_ns`` (all that remain when None), in time order."""
        imu = None if self._rig is None else self._rig.imu
        if imu is None:
            return
        rate = imu.rate_hz
        n = imu.noise
        var = (n.gyroscope_noise_density**2 * rate, n.accelerometer_noise_density**2 * rate)
        while self._imu_next < len(imu.t):
            k = self._imu_next
            ns = stamp_ns(imu.t[k])
            if until_ns is not None and ns > until_ns:
                break
            self._put(f"/{self.robot}/imu", ns, self._msgs.imu(ns, imu.gyro[k], imu.accel[k], var))
            self._imu_next += 1

    def _put(self, topic: str, ns: int, msg: Msg) -> None:
        self._writer.write(self._conn[topic], ns, self._msgs.ts.serialize_cdr(msg, msg.__msgtype__))
        self._counts[topic] += 1

    def topic_table(self, robot: str) -> dict[str, str]:
        """Topic name -> message type of the bag (``topics``)."""
        return topics(robot)

    def write(self, frame: Frame) -> None:
        """Write one frame's messages (``frame_messages``) and its mask."""
        if frame.rgb is None or frame.truth is None:
            raise StorageError(f"rosbag2 export: frame {frame.index} of robot {frame.robot} needs RGB and truth")
        ns = stamp_ns(frame.t)
        if self._prev is not None and ns <= self._prev[0]:
            raise StorageError(f"rosbag2 export: frame {frame.index}: time stamp does not increase")
        if self._prev is None:
            self._put("/tf_static", ns, self._static(ns))
        self._write_imu(ns)
        T_ob = np.asarray(frame.T_odom_body, dtype=np.float64)
        for topic, msg in self.frame_messages(frame, ns, T_ob):
            self._put(topic, ns, msg)
        self._masks.write(frame, stamp_text(ns))
        self._prev = (ns, T_ob)

    def odometry(self, ns: int, T_ob: NDArray[np.float64]) -> Msg:
        """The body odometry message (twist from the previous frame's pose)."""
        dt = 0.0 if self._prev is None else (ns - self._prev[0]) / 1e9
        v, w = body_twist(None if self._prev is None else self._prev[1], T_ob, dt)
        return self._msgs.odometry(ns, T_ob, v, w)

    def frame_messages(self, frame: Frame, ns: int, T_ob: NDArray[np.float64]) -> list[tuple[str, Msg]]:
        """(topic, message) of one frame, in writing order."""
        r, m = self.robot, self._msgs
        assert frame.truth is not None and frame.rgb is not None
        depth = np.asarray(frame.depth, dtype=np.float32)
        depth = np.where(np.isfinite(depth) & (depth > 0), depth, np.float32(np.nan)).astype("<f4")
        return [
            (color_topic(r), self._color(ns, frame.rgb)),
            (f"/{r}/camera/color/camera_info", m.camera_info(ns)),
            (f"/{r}/camera/depth/image", m.image(ns, depth, "32FC1")),
            (f"/{r}/camera/depth/camera_info", m.camera_info(ns)),
            (f"/{r}/odom", self.odometry(ns, T_ob)),
            (
                "/tf",
                m.tf(
                    [
                        m.transform(ns, "world", f"{r}/base_link_gt", frame.truth.T_world_body),
                        m.transform(ns, f"{r}/odom", f"{r}/base_link", T_ob),
                    ]
                ),
            ),
            *self._right_messages(frame, ns),
        ]

    def _right_messages(self, frame: Frame, ns: int) -> list[tuple[str, Msg]]:
        """The second camera's image and camera info (none without a second camera)."""
        if self._rig is None or self._rig.T_cam_cam2 is None:
            return []
        if frame.rgb_right is None:
            raise StorageError(f"rosbag2 export: frame {frame.index} of robot {frame.robot} has no second image")
        r, m = self.robot, self._msgs
        right = f"{r}/camera_right_optical_frame"
        Tx = -float(self.intr.fx) * float(self._rig.T_cam_cam2[0, 3])
        return [
            (f"/{r}/camera/right/image_raw", self._color(ns, frame.rgb_right, right)),
            (f"/{r}/camera/right/camera_info", m.camera_info(ns, right, Tx)),
        ]

    def close(self) -> dict[str, JSONLike]:
        """Finish the bag, move it to ``out_dir/bag``, write ``masks.txt``; returns message counts."""
        if self._prev is None:
            self.abort()
            raise StorageError(f"rosbag2 export: robot {self.robot} has no frames")
        self._write_imu(None)
        self._writer.close()
        os.replace(self._tmp_parent / BAG_DIR, self.final)
        shutil.rmtree(self._tmp_parent, ignore_errors=True)
        self._masks.close()
        if self._rig is not None and (self._rig.imu is not None or self._rig.T_cam_cam2 is not None):
            write_kalibr(self.dir, self.robot, self.intr, self.T_bc, self._rig)
        return {"frames": self._counts[f"/{self.robot}/odom"], "messages": dict(self._counts), "bag": str(self.final)}

    def abort(self) -> None:
        """Close and delete the unfinished bag."""
        try:
            self._writer.close()
        except Exception:
            log.debug("closing an aborted bag failed", exc_info=True)
        shutil.rmtree(self._tmp_parent, ignore_errors=True)


FORMATS.register("rosbag2", RosbagWriter)
