"""ROS 2 bag export, opened with ``rosbags``' own reader: topics, types, counts, contents."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from rosbags.interfaces import QosDurability
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation

from roman_sim.interop.associate import read_list
from roman_sim.interop.images import read_png
from roman_sim.interop.rosbag_writer import body_twist, topics

from .conftest import EPOCH_NS, FRAMES

TYPES = get_typestore(Stores.ROS2_HUMBLE)


def _pose(translation, rotation) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [translation.x, translation.y, translation.z]
    T[:3, :3] = Rotation.from_quat([rotation.x, rotation.y, rotation.z, rotation.w]).as_matrix()
    return T


def _messages(bag: Path) -> dict[str, list[tuple[int, object]]]:
    out: dict[str, list[tuple[int, object]]] = {}
    with Reader(bag) as reader:
        for conn, stamp, raw in reader.messages():
            out.setdefault(conn.topic, []).append((stamp, TYPES.deserialize_cdr(raw, conn.msgtype)))
    return out


@pytest.mark.parametrize("robot", sorted(FRAMES))
def test_topics_types_and_counts(bag_export: Path, robot: str) -> None:
    with Reader(bag_export / robot / "bag") as reader:
        found = {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}
        static = next(c for c in reader.connections if c.topic == "/tf_static")
        assert static.ext.offered_qos_profiles[0].durability == QosDurability.TRANSIENT_LOCAL
        assert reader.message_count == 6 * FRAMES[robot] + 1
    expected = {t: (m, 1 if t == "/tf_static" else FRAMES[robot]) for t, m in topics(robot).items()}
    assert found == expected


def test_contents_match_the_frames(bag_export: Path, direct_frames: dict) -> None:
    frames = direct_frames["a"]
    msgs = _messages(bag_export / "a" / "bag")
    stamps = [EPOCH_NS + round(f.t * 1e9) for f in frames]
    for topic, rows in msgs.items():
        if topic != "/tf_static":
            assert [s for s, _ in rows] == stamps, topic
            heads = [m.transforms[0].header if topic == "/tf" else m.header for _, m in rows]
            headers = [h.stamp for h in heads]
            assert [h.sec * 1_000_000_000 + h.nanosec for h in headers] == stamps, topic
    for f, (_, img), (_, depth), (_, info), (_, odom), (_, tf) in zip(
        frames,
        msgs["/a/camera/color/image_raw"],
        msgs["/a/camera/depth/image"],
        msgs["/a/camera/color/camera_info"],
        msgs["/a/odom"],
        msgs["/tf"],
    ):
        assert (img.encoding, img.header.frame_id, img.step) == ("rgb8", "a/camera_optical_frame", 160 * 3)
        np.testing.assert_array_equal(np.asarray(img.data).reshape(120, 160, 3), f.rgb)
        assert (depth.encoding, depth.step) == ("32FC1", 160 * 4)
        d = np.frombuffer(bytes(depth.data), dtype="<f4").reshape(120, 160)
        np.testing.assert_array_equal(np.nan_to_num(d, nan=0.0), f.depth)  # exact: float32 metres, NaN = none
        np.testing.assert_allclose(np.asarray(info.k).reshape(3, 3), f.intrinsics.K)
        assert (odom.header.frame_id, odom.child_frame_id) == ("a/odom", "a/base_link")
        p = odom.pose.pose
        np.testing.assert_allclose(_pose(p.position, p.orientation), f.T_odom_body, atol=1e-9)
        by_child = {x.child_frame_id: x for x in tf.transforms}
        truth = by_child["a/base_link_gt"]
        assert truth.header.frame_id == "world"
        np.testing.assert_allclose(
            _pose(truth.transform.translation, truth.transform.rotation), f.truth.T_world_body, atol=1e-9
        )
        assert by_child["a/base_link"].header.frame_id == "a/odom"
    ((_, static),) = msgs["/tf_static"]
    mount = static.transforms[0]
    assert (mount.header.frame_id, mount.child_frame_id) == ("a/base_link", "a/camera_optical_frame")
    np.testing.assert_allclose(
        _pose(mount.transform.translation, mount.transform.rotation), frames[0].T_body_cam, atol=1e-9
    )


def test_odometry_twist_is_the_pose_difference(bag_export: Path, direct_frames: dict) -> None:
    frames = direct_frames["a"]
    odom = [m for _, m in _messages(bag_export / "a" / "bag")["/a/odom"]]
    v, w = body_twist(frames[2].T_odom_body, frames[3].T_odom_body, frames[3].t - frames[2].t)
    t = odom[3].twist.twist
    np.testing.assert_allclose([t.linear.x, t.linear.y, t.linear.z], v, atol=1e-6)
    np.testing.assert_allclose([t.angular.x, t.angular.y, t.angular.z], w, atol=1e-6)
    assert 0.5 < v[0] < 1.5  # the robot drives forward at about 1 m/s
    assert odom[0].twist.twist.linear.x == 0.0


def test_mask_side_files(bag_export: Path, direct_frames: dict) -> None:
    for robot, frames in direct_frames.items():
        _, files = read_list(bag_export / robot / "masks.txt")
        assert len(files) == FRAMES[robot]
        for f, name in zip(frames, files):
            np.testing.assert_array_equal(read_png(bag_export / robot / name).astype(np.int32) - 1, f.truth.object_ids)
    assert (bag_export / "objects.json").is_file() and (bag_export / "objects.csv").is_file()


def test_same_seed_same_bytes(bag_export: Path, tiny_scenario, tmp_path: Path) -> None:
    from roman_sim.interop import export_scenario

    export_scenario(tiny_scenario, "rosbag2", tmp_path / "again", robots=["b"])
    for name in ("bag/bag.mcap", "bag/metadata.yaml", "masks.txt"):
        assert (
            hashlib.sha256((tmp_path / "again" / "b" / name).read_bytes()).digest()
            == hashlib.sha256((bag_export / "b" / name).read_bytes()).digest()
        ), name


def test_sqlite3_storage(tiny_scenario, tmp_path: Path) -> None:
    from roman_sim.interop import export_scenario

    export_scenario(tiny_scenario, "rosbag2", tmp_path / "sq", robots=["b"], storage="sqlite3")
    with Reader(tmp_path / "sq" / "b" / "bag") as reader:
        assert reader.message_count == 6 * FRAMES["b"] + 1
    assert not list((tmp_path / "sq" / "b").glob(".bag.*"))  # the temporary folder is gone


@pytest.fixture(scope="module")
def rig_exports(tmp_path_factory: pytest.TempPathFactory):
    """Robot a of the tiny scenario with an IMU (D455 noise) and a second camera, as rosbag2 and roman bags."""
    import copy

    from roman_sim.core.config import validate_model
    from roman_sim.interop import export_scenario
    from roman_sim.interop.source import scenario_streams
    from roman_sim.pipeline.scenario import Scenario

    from .conftest import TINY

    data = copy.deepcopy(TINY)
    data["robots"][0].update(imu={"preset": "d455"}, stereo={"baseline_m": 0.12})
    sc = validate_model(Scenario, data, source="rig")
    out = tmp_path_factory.mktemp("rig")
    for fmt in ("rosbag2", "roman"):
        export_scenario(sc, fmt, out / fmt, robots=["a"])
    _, (stream,) = scenario_streams(sc, ["a"])
    return out, stream, list(stream.frames([0, 18]))


def test_imu_and_second_camera_topics(rig_exports) -> None:
    from roman_sim.core.geometry import make_T

    out, stream, (first, last) = rig_exports
    imu = stream.rig().imu
    assert imu is not None and imu.noisy and len(imu.t) == 33 * 18 + 1
    noise = imu.noise
    for fmt, encoding in (("rosbag2", "rgb8"), ("roman", "bgr8")):
        msgs = _messages(out / fmt / "a" / "bag")
        assert len(msgs["/a/camera/right/image_raw"]) == len(msgs["/a/camera/right/camera_info"]) == FRAMES["a"]
        rows = msgs["/a/imu"]
        assert [s for s, _ in rows] == [EPOCH_NS + round(t * 1e9) for t in imu.t]
        for k in (0, 1, 300, len(rows) - 1):
            m = rows[k][1]
            assert m.header.frame_id == "a/imu_link" and m.orientation_covariance[0] == -1.0
            g, a = m.angular_velocity, m.linear_acceleration
            np.testing.assert_array_equal([g.x, g.y, g.z], imu.gyro[k])
            np.testing.assert_array_equal([a.x, a.y, a.z], imu.accel[k])
            assert m.angular_velocity_covariance[0] == pytest.approx(noise.gyroscope_noise_density**2 * 198.0)
            assert m.linear_acceleration_covariance[8] == pytest.approx(noise.accelerometer_noise_density**2 * 198.0)
        for f, (_, img), (_, info) in zip(
            (first, last),
            (msgs["/a/camera/right/image_raw"][0], msgs["/a/camera/right/image_raw"][-1]),
            (msgs["/a/camera/right/camera_info"][0], msgs["/a/camera/right/camera_info"][-1]),
        ):
            assert (img.encoding, img.header.frame_id) == (encoding, "a/camera_right_optical_frame")
            pixels = np.asarray(img.data).reshape(120, 160, 3)
            np.testing.assert_array_equal(pixels if encoding == "rgb8" else pixels[..., ::-1], f.rgb_right)
            assert info.p[3] == pytest.approx(-f.intrinsics.fx * 0.12) and info.p[0] == f.intrinsics.fx
        ((_, static),) = msgs["/tf_static"]
        mounts = {t.child_frame_id: _pose(t.transform.translation, t.transform.rotation) for t in static.transforms}
        T_bc = first.T_body_cam
        np.testing.assert_allclose(mounts["a/camera_optical_frame"], T_bc, atol=1e-9)
        np.testing.assert_allclose(mounts["a/camera_right_optical_frame"], T_bc @ make_T(t=[0.12, 0, 0]), atol=1e-9)
        np.testing.assert_allclose(mounts["a/imu_link"], np.eye(4), atol=1e-12)
        assert (out / fmt / "a" / "kalibr" / "camchain.yaml").is_file()
        assert (out / fmt / "a" / "kalibr" / "imu.yaml").is_file()
