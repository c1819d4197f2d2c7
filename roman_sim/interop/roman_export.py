"""ROMAN-ready export (``--format roman``): bags and parameter folders the reference ROMAN reads with its defaults.

Each robot's ROS 2 bag (``<robot>/bag``, sqlite3 storage by default: Humble's; metadata
version 8, which Humble and newer read) holds, besides ``/r/odom``, ``/tf`` and
``/tf_static`` of the ``rosbag2`` export:

=====================================  ============================  =============================
topic                                  type                          content
=====================================  ============================  =============================
``/r/camera/color/image_raw``          sensor_msgs/msg/Image         ``bgr8`` (OpenCV's order)
``/r/camera/color/camera_info``        sensor_msgs/msg/CameraInfo    pinhole, no distortion
``/r/camera/depth/image_raw``          sensor_msgs/msg/Image         ``16UC1`` millimetres, 0 = no
                                                                     reading (REP 118)
``/r/camera/depth/camera_info``        sensor_msgs/msg/CameraInfo    same camera
``/r/camera/odom``                     nav_msgs/msg/Odometry         drifted odometry of the
                                                                     **camera** (``T_odom_cam``)
``/r/groundtruth``                     nav_msgs/msg/Odometry         true **body** pose (FLU,
                                                                     ``T_world_body``)
=====================================  ============================  =============================

Depth is ``round(1000 * metres)``: within 0.5 mm of the rendered depth; a reading beyond
65.535 m does not fit and is 0. Each robot's folder also holds ``groundtruth.csv``, the
truth topic's poses in the reference's CSV layout (``#timestamp_kf,x,y,z,qw,qx,qy,qz``,
nanoseconds): its ``gt_pose.yaml`` expands ``${ROBOT}`` in a path but not in a topic, so the
truth of each robot is read from its own file. The parameter folders ``roman_params/``
(FastSAM and DINOv2 on a GPU, the reference's ``params/demo``) and ``roman_params_cpu/``
(``params/demo_no_gpu``: FastSAM on the CPU, no semantics) hold ``data.yaml`` (paths to the
bags relative to the export folder, the robots as ``runs``, ``dt`` the frame interval
``1 / rate_hz`` as configured, the camera-pose topic with ``T_camera_flu`` = the camera
mount's inverse for each robot), ``fastsam.yaml`` (``depth_scale: 1000``, the camera's
``max_depth``), ``mapper.yaml``, ``submap_align.yaml`` (the scenario's submap settings),
``offline_rpgo.yaml`` and ``gt_pose.yaml`` (the truth files). Relative paths resolve against
the working directory: run the reference from the export folder, which can then be moved.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_text
from roman_sim.core.geometry import inv_T
from roman_sim.core.jsontypes import JSONLike
from roman_sim.core.sensors import Frame
from roman_sim.interop.base import FORMATS
from roman_sim.interop.rig import matrix_rows
from roman_sim.interop.rosbag_writer import BAG_DIR, RosbagWriter, topics

if TYPE_CHECKING:
    from rosbags.typesys.store import Msg

log = logging.getLogger(__name__)

#: Depth units per metre of ``16UC1`` images (the reference front end's ``depth_scale``).
DEPTH_SCALE = 1000.0
#: Each robot's truth in its folder, in the reference's CSV layout (what ``gt_pose.yaml`` reads).
TRUTH_CSV = "groundtruth.csv"
#: ``gt_pose.yaml``'s reading of ``TRUTH_CSV`` (robotdatapy's ``PoseData.from_csv`` options).
TRUTH_CSV_OPTIONS = {
    "cols": {"time": ["#timestamp_kf"], "position": ["x", "y", "z"], "orientation": ["qx", "qy", "qz", "qw"]},
    "col_nums": {"time": [0], "position": [1, 2, 3], "orientation": [5, 6, 7, 4]},
    "timescale": 1e-9,
}


def truth_topic(robot: str) -> str:
    """The robot's truth topic (one per robot, so bags played together do not mix)."""
    return f"/{robot}/groundtruth"


#: Parameter folders: name -> (FastSAM device, semantics).
PARAM_DIRS = {"roman_params": ("cuda", True), "roman_params_cpu": ("cpu", False)}


def roman_topics(robot: str) -> dict[str, str]:
    """Topic name -> message type of one robot's ROMAN-ready bag."""
    out = {k: v for k, v in topics(robot).items() if k != f"/{robot}/camera/depth/image"}
    out[f"/{robot}/camera/depth/image_raw"] = "sensor_msgs/msg/Image"
    out[f"/{robot}/camera/odom"] = "nav_msgs/msg/Odometry"
    out[truth_topic(robot)] = "nav_msgs/msg/Odometry"
    return out


def depth_mm(depth_m: NDArray[np.floating]) -> NDArray[np.uint16]:
    """Depth in millimetres as ``uint16`` (0: no reading, or too deep for 16 bits)."""
    d = np.asarray(depth_m, dtype=np.float64)
    ok = np.isfinite(d) & (d > 0) & (d * DEPTH_SCALE <= 65535.0)
    return np.where(ok, np.rint(np.where(ok, d, 0.0) * DEPTH_SCALE), 0).astype("<u2")


class RomanBagWriter(RosbagWriter):
    """One robot's ROMAN-ready bag (module docstring) and its mask side files."""

    default_storage = "sqlite3"
    color_encoding = "bgr8"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._truth: list[tuple[int, NDArray[np.float64]]] = []

    def topic_table(self, robot: str) -> dict[str, str]:
        """``roman_topics``."""
        return roman_topics(robot)

    def frame_messages(self, frame: Frame, ns: int, T_ob: NDArray[np.float64]) -> list[tuple[str, Msg]]:
        """The ``rosbag2`` messages with BGR colour, millimetre depth, camera odometry and the truth topic."""
        r, m = self.robot, self._msgs
        assert frame.truth is not None and frame.rgb is not None
        zero = np.zeros(3)
        out = []
        for topic, msg in super().frame_messages(frame, ns, T_ob):
            if topic == f"/{r}/camera/depth/image":
                topic, msg = f"/{r}/camera/depth/image_raw", m.image(ns, depth_mm(frame.depth), "16UC1")
            out.append((topic, msg))
        out.append((f"/{r}/camera/odom", m.odometry(ns, T_ob @ self.T_bc, zero, zero, child=m.cam_frame)))
        truth = m.odometry(ns, frame.truth.T_world_body, zero, zero, frame_id="world", child=f"{r}/base_link_gt")
        out.append((truth_topic(r), truth))
        self._truth.append((ns, np.asarray(frame.truth.T_world_body, dtype=np.float64)))
        return out

    def close(self) -> dict[str, JSONLike]:
        """Finish the bag (``RosbagWriter.close``) and write ``groundtruth.csv``."""
        summary = super().close()
        write_text(self.dir / TRUTH_CSV, truth_csv(self._truth))
        return summary

    @staticmethod
    def finish_export(out: Path, scenario: Any, streams: Sequence[Any], robots: Mapping[str, object]) -> None:
        """Write the parameter folders for the exported robots (``streams``)."""
        write_roman_params(out, scenario, streams)


def truth_csv(rows: Sequence[tuple[int, NDArray[np.float64]]]) -> str:
    """The reference's trajectory CSV (``#timestamp_kf,x,y,z,qw,qx,qy,qz``, nanoseconds) of stamped poses."""
    lines = ["#timestamp_kf,x,y,z,qw,qx,qy,qz\n"]
    for ns, T in rows:
        x, y, z, w = Rotation.from_matrix(T[:3, :3]).as_quat()
        vals = (*T[:3, 3], w, x, y, z)
        lines.append(f"{ns}," + ",".join(f"{float(v):.9f}" for v in vals) + "\n")
    return "".join(lines)


def _dt(stream: Any) -> float:
    """The frame interval as configured: ``1 / rate_hz``."""
    return 1.0 / float(stream.cfg.rate_hz)


def _data_yaml(streams: Sequence[Any]) -> dict[str, Any]:
    bag = "${ROBOT}/" + BAG_DIR
    image = {"type": "bag", "path": bag, "compressed": False, "ignore_ros_time": True}
    doc: dict[str, Any] = {
        "dt": _dt(streams[0]),
        "runs": [s.name for s in streams],
        "run_env": "ROBOT",
        "img_data": {
            **image,
            "topic": "/${ROBOT}/camera/color/image_raw",
            "camera_info_topic": "/${ROBOT}/camera/color/camera_info",
        },
        "depth_data": {
            **image,
            "topic": "/${ROBOT}/camera/depth/image_raw",
            "camera_info_topic": "/${ROBOT}/camera/depth/camera_info",
        },
        "pose_data": {
            "type": "bag",
            "path": bag,
            "topic": "/${ROBOT}/camera/odom",
            "time_tol": 10.0,
            "ignore_ros_time": True,
            "T_camera_flu": {"input_type": "matrix", "matrix": matrix_rows(inv_T(streams[0].T_body_cam))},
        },
    }
    for s in streams:  # each robot's own mount (the reference merges a run's section over the top level)
        own: dict[str, Any] = {
            "pose_data": {"T_camera_flu": {"input_type": "matrix", "matrix": matrix_rows(inv_T(s.T_body_cam))}}
        }
        if _dt(s) != doc["dt"]:
            own["dt"] = _dt(s)
        doc[s.name] = own
    return doc


def _fastsam_yaml(device: str, semantics: bool, max_depth_m: float) -> dict[str, Any]:
    return {
        "weights_path": "$ROMAN_WEIGHTS/FastSAM-x.pt",
        "yolo_weights_path": "$ROMAN_WEIGHTS/yolov7.pt",
        "imgsz": [256, 256],
        "device": device,
        "mask_downsample_factor": 8,
        "min_mask_len_div": 30,
        "max_mask_len_div": 3,
        "ignore_people": False,
        "erosion_size": 3,
        "voxel_size": 0.05,
        "ignore_labels": ["person"],
        "use_keep_labels": False,
        "keep_labels": [],
        "plane_filter_params": [3.0, 1.0, 0.2],
        "semantics": "dino" if semantics else "none",
        "yolo_imgsz": [256, 256],
        "depth_scale": DEPTH_SCALE,
        "max_depth": float(max_depth_m),
        "frame_descriptor": "dino-gem" if semantics else "none",
    }


MAPPER = {
    "geometric_association_method": "iou",
    "semantic_association_method": "none",
    "geometric_score_range": [0.25, 1.0],
    "semantic_score_range": [0.8, 1.0],
    "min_sightings": 2,
    "max_t_no_sightings": 0.4,
    "mask_downsample_factor": 8,
    "min_max_extent": 0.25,
    "plane_prune_params": [3.0, 3.0, 0.5],
    "segment_graveyard_time": 15.0,
    "segment_graveyard_dist": 10.0,
    "iou_voxel_size": 0.2,
    "segment_voxel_size": 0.05,
}
RPGO = {"odom_t_std": 0.02, "odom_r_std": 0.001745, "lc_t_std": 2.0, "lc_r_std": 0.1745, "sparsified": False}


def _submap_align_yaml(submaps: Any, semantics: bool) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "dim": 3,
        "method": "roman" if semantics else "roman_no_semantics",
        "fusion_method": "geometric_mean",
        "submap_radius": float(submaps.submap_radius),
        "submap_center_dist": float(submaps.submap_center_dist),
        "submap_center_time": float(submaps.submap_center_time),
        "submap_max_size": int(submaps.submap_max_size),
        "single_robot_lc": False,
        "single_robot_lc_time_thresh": 50.0,
        "force_rm_lc_roll_pitch": False,
        "force_rm_upside_down": True,
        "use_object_bottom_middle": True,
    }
    if semantics:
        doc.update(
            cosine_min=0.5,
            cosine_max=0.7,
            semantics_dim=768,
            submap_descriptor="stacked_frame_descriptors",
            frame_descriptor_dist=10.0,
            submap_descriptor_thresh=0.8,
        )
    return doc


def write_roman_params(out: Path, scenario: Any, streams: Sequence[Any]) -> list[Path]:
    """Write ``roman_params/`` and ``roman_params_cpu/`` for ``streams``' robots; the files written."""
    data = _data_yaml(streams)
    gt = {
        "type": "csv",
        "path": "${ROBOT}/" + TRUTH_CSV,
        "csv_options": TRUTH_CSV_OPTIONS,
        "time_tol": 10.0,
        "interp": True,
    }
    max_depth = min(float(s.cfg.camera.max_depth_m) for s in streams)
    written = []
    for folder, (device, semantics) in PARAM_DIRS.items():
        files = {
            "data.yaml": data,
            "fastsam.yaml": _fastsam_yaml(device, semantics, max_depth),
            "mapper.yaml": MAPPER,
            "submap_align.yaml": _submap_align_yaml(scenario.submaps, semantics),
            "offline_rpgo.yaml": RPGO,
            "gt_pose.yaml": gt,
        }
        for name, doc in files.items():
            path = out / folder / name
            write_text(path, yaml.safe_dump(doc, sort_keys=False))
            written.append(path)
    log.info("ROMAN parameter folders written in %s", out)
    return written


FORMATS.register("roman", RomanBagWriter)
