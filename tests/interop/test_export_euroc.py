"""EuRoC MAV export, read back by a plain parser written here (and evo's ground-truth reader).

The smoke drive (robot a, 536 frames, 89 s; images shrunk to 64 x 48, which changes no pose)
is exported with a noise-free IMU and a second camera. Integrating the exported IMU readings
from the first exported true state (pose and velocity) gives the simulator's true positions
back within 1 cm at every frame: the readings are the analytic derivatives of a C2 spline
through the frame poses, and the second-order integrator below (midpoint rotation,
trapezoidal velocity) at 198 Hz is accurate to about 0.5 mm over the drive.

Stereo: a flat textured wall 5 m in front of a D455-like pair (640 x 480, 87 deg, 95 mm
baseline) is rendered, exported and matched: the disparity d (about 6.4 px, found by SSD
over sub-pixel shifts of the right image) gives ``Z = fx * B / d`` within 1 % of the rendered
depth. Sub-pixel matching of rendered texture locks towards whole and half pixels by up to
about 0.05 px (0.7 % here), which the 1 % bound leaves room for.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from roman_sim.core.geometry import inv_T, make_T

from .conftest import EPOCH_NS

IMU_HEADER = [
    "#timestamp [ns]",
    "w_RS_S_x [rad s^-1]",
    "w_RS_S_y [rad s^-1]",
    "w_RS_S_z [rad s^-1]",
    "a_RS_S_x [m s^-2]",
    "a_RS_S_y [m s^-2]",
    "a_RS_S_z [m s^-2]",
]
GT_HEADER = ["#timestamp", "p_RS_R_x [m]", "p_RS_R_y [m]", "p_RS_R_z [m]", "q_RS_w []", "q_RS_x []", "q_RS_y []"]
GT_HEADER += ["q_RS_z []", "v_RS_R_x [m s^-1]", "v_RS_R_y [m s^-1]", "v_RS_R_z [m s^-1]", "b_w_RS_S_x [rad s^-1]"]
GT_HEADER += ["b_w_RS_S_y [rad s^-1]", "b_w_RS_S_z [rad s^-1]", "b_a_RS_S_x [m s^-2]", "b_a_RS_S_y [m s^-2]"]
GT_HEADER += ["b_a_RS_S_z [m s^-2]"]
SMOKE = ["robots.0.camera.width=64", "robots.0.camera.height=48", "robots.0.imu.noise=false"]
SMOKE += ["robots.0.stereo.baseline_m=0.095"]
G = 9.81  # the IMU's default gravity (imu.gravity_mps2)


def _table(path: Path) -> tuple[list[str], list[list[str]]]:
    """Header cells (stripped) and rows of an EuRoC CSV."""
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    return [c.strip() for c in rows[0]], rows[1:]


def _numbers(rows: list[list[str]]) -> tuple[np.ndarray, np.ndarray]:
    """Integer stamps (ns) and the float columns."""
    return np.array([int(r[0]) for r in rows], dtype=np.int64), np.array([[float(v) for v in r[1:]] for r in rows])


def _matrix(block: dict[str, Any]) -> np.ndarray:
    assert (block["rows"], block["cols"]) == (4, 4)
    return np.asarray(block["data"], dtype=np.float64).reshape(4, 4)


@dataclass
class Euroc:
    """What the parser reads of one ``<robot>/`` folder."""

    cams: dict[str, tuple[np.ndarray, list[str], dict[str, Any]]]
    imu: tuple[np.ndarray, np.ndarray, dict[str, Any]]
    gt: tuple[np.ndarray, np.ndarray]
    camchain: dict[str, Any]
    kalibr_imu: dict[str, Any]


def read_euroc(folder: Path) -> Euroc:
    mav = folder / "mav0"
    cams = {}
    for cam in ("cam0", "cam1"):
        header, rows = _table(mav / cam / "data.csv")
        assert header == ["#timestamp [ns]", "filename"]
        stamps = np.array([int(r[0]) for r in rows], dtype=np.int64)
        assert [r[1] for r in rows] == [f"{s}.png" for s in stamps]
        cams[cam] = (stamps, [r[1] for r in rows], yaml.safe_load((mav / cam / "sensor.yaml").read_text()))
    header, rows = _table(mav / "imu0" / "data.csv")
    assert header == IMU_HEADER
    t_imu, imu = _numbers(rows)
    header, rows = _table(mav / "state_groundtruth_estimate0" / "data.csv")
    assert header == GT_HEADER
    kalibr = folder / "kalibr"
    return Euroc(
        cams,
        (t_imu, imu, yaml.safe_load((mav / "imu0" / "sensor.yaml").read_text())),
        _numbers(rows),
        yaml.safe_load((kalibr / "camchain.yaml").read_text()),
        yaml.safe_load((kalibr / "imu.yaml").read_text()),
    )


@pytest.fixture(scope="module")
def smoke_truth() -> Any:
    """The smoke scenario's robot a as the simulator drives it (no rendering)."""
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.sim.source import robot_sources
    from roman_sim.world.build import generate_truth

    sc = load_scenario("smoke", SMOKE)
    (a,) = robot_sources(generate_truth(sc.world.spec(), sc.seed), sc.robots, sc.seed, ["a"])
    return a


@pytest.fixture(scope="module")
def smoke_euroc(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from roman_sim.interop import export_scenario
    from roman_sim.pipeline.scenario import load_scenario

    out = tmp_path_factory.mktemp("euroc") / "smoke"
    export_scenario(load_scenario("smoke", SMOKE), "euroc", out, robots=["a"])
    return out / "a"


def _integrate(t_ns: np.ndarray, imu: np.ndarray, p0: np.ndarray, q0_wxyz: np.ndarray, v0: np.ndarray) -> np.ndarray:
    """Positions (M, 3) at the IMU stamps: midpoint rotation, trapezoidal velocity, gravity -G on world z."""
    t = (t_ns - t_ns[0]) / 1e9
    R = Rotation.from_quat(np.roll(q0_wxyz, -1)).as_matrix()
    p, v, g = p0.astype(float), v0.astype(float), np.array([0.0, 0.0, -G])
    out = [p.copy()]
    for k in range(len(t) - 1):
        h = t[k + 1] - t[k]
        R_next = R @ Rotation.from_rotvec(0.5 * (imu[k, :3] + imu[k + 1, :3]) * h).as_matrix()
        a0, a1 = R @ imu[k, 3:] + g, R_next @ imu[k + 1, 3:] + g
        p = p + v * h + h * h * (2 * a0 + a1) / 6
        v = v + 0.5 * h * (a0 + a1)
        R = R_next
        out.append(p.copy())
    return np.array(out)


def test_noise_free_imu_integrates_back_to_the_smoke_drive(smoke_euroc: Path, smoke_truth: Any) -> None:
    e = read_euroc(smoke_euroc)
    t_imu, imu, sensor = e.imu
    t_cam = e.cams["cam0"][0]
    truth = smoke_truth.run
    assert len(t_cam) == len(truth.t) == 536 and truth.t[-1] > 89.0
    assert len(t_imu) == 33 * 535 + 1 and sensor["rate_hz"] == 198.0
    np.testing.assert_array_equal(t_cam, EPOCH_NS + np.round(truth.t * 1e9).astype(np.int64))
    t_gt, gt = e.gt
    np.testing.assert_array_equal(t_gt, t_imu)
    assert np.all(gt[:, 10:] == 0.0)  # noise-free: no bias
    at_frames = np.searchsorted(t_gt, t_cam)
    np.testing.assert_array_equal(t_gt[at_frames], t_cam)
    np.testing.assert_allclose(gt[at_frames, :3], truth.T_world_body[:, :3, 3], atol=1e-9)
    R_gt = Rotation.from_quat(np.roll(gt[at_frames, 3:7], -1, axis=1)).as_matrix()
    np.testing.assert_allclose(R_gt, truth.T_world_body[:, :3, :3], atol=1e-9)
    positions = _integrate(t_imu, imu, gt[0, :3], gt[0, 3:7], gt[0, 7:10])
    err = np.linalg.norm(positions[np.searchsorted(t_imu, t_cam)] - truth.T_world_body[:, :3, 3], axis=1)
    assert err.max() < 0.01, err.max()
    # the same readings with gravity's sign flipped drift away: the bound is not vacuous
    flipped = imu.copy()
    flipped[:, 5] -= 2 * G
    wrong = _integrate(t_imu[:200], flipped[:200], gt[0, :3], gt[0, 3:7], gt[0, 7:10])
    assert np.linalg.norm(wrong[-1] - gt[199, :3]) > 1.0


def test_cameras_and_calibration_files(smoke_euroc: Path, smoke_truth: Any) -> None:
    from PIL import Image

    e = read_euroc(smoke_euroc)
    (s0, files0, cam0), (s1, _, cam1) = e.cams["cam0"], e.cams["cam1"]
    np.testing.assert_array_equal(s0, s1)
    for name in (files0[0], files0[-1]):
        for cam in ("cam0", "cam1"):
            with Image.open(smoke_euroc / "mav0" / cam / "data" / name) as img:
                assert (img.mode, img.size) == ("L", (64, 48))
    k = smoke_truth.intrinsics
    fx, fy = cam0["intrinsics"][:2]
    assert fx == fy == k.fx == k.fy  # the bundled scenario's camera has square pixels
    T_bc = smoke_truth.T_body_cam
    shift = make_T(np.eye(3), [0.095, 0.0, 0.0])
    for cam, T in ((cam0, T_bc), (cam1, T_bc @ shift)):
        assert cam["sensor_type"] == "camera" and cam["camera_model"] == "pinhole"
        assert cam["resolution"] == [64, 48] and cam["rate_hz"] == 6.0
        np.testing.assert_allclose(cam["intrinsics"], [k.fx, k.fy, k.cx, k.cy], atol=1e-12)
        assert cam["distortion_model"] == "radial-tangential" and cam["distortion_coefficients"] == [0.0] * 4
        np.testing.assert_allclose(_matrix(cam["T_BS"]), T, atol=1e-12)
    np.testing.assert_allclose(_matrix(e.imu[2]["T_BS"]), np.eye(4))
    chain = e.camchain
    assert chain["cam0"]["rostopic"] == "/a/camera/color/image_raw"
    assert chain["cam1"]["rostopic"] == "/a/camera/right/image_raw"
    T_c1_c0 = np.asarray(chain["cam1"]["T_cn_cnm1"])
    np.testing.assert_allclose(T_c1_c0[:3, 3], [-0.095, 0.0, 0.0], atol=1e-12)  # cam0's origin seen from cam1
    for name, T in (("cam0", T_bc), ("cam1", T_bc @ shift)):
        c = chain[name]
        np.testing.assert_allclose(np.asarray(c["T_cam_imu"]), inv_T(T), atol=1e-12)
        assert c["intrinsics"] == e.cams["cam0"][2]["intrinsics"] and c["resolution"] == [64, 48]
        assert (c["distortion_model"], c["timeshift_cam_imu"]) == ("radtan", 0.0)
    # a point in the body frame lands in cam1 the same way through either chain of transforms
    p = np.array([3.0, 0.4, 0.7, 1.0])
    np.testing.assert_allclose(
        T_c1_c0 @ np.asarray(chain["cam0"]["T_cam_imu"]) @ p, np.asarray(chain["cam1"]["T_cam_imu"]) @ p
    )
    ki = e.kalibr_imu
    assert ki["update_rate"] == 198.0 and ki["rostopic"] == "/a/imu"
    assert ki["gyroscope_noise_density"] == pytest.approx(0.014 * np.pi / 180)
    assert ki["accelerometer_noise_density"] == pytest.approx(150e-6 * 9.80665)
    for key in ("gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density"):
        assert e.imu[2][key] == ki[key]


def test_evo_reads_the_ground_truth(smoke_euroc: Path) -> None:
    file_interface = pytest.importorskip("evo.tools.file_interface")
    traj = file_interface.read_euroc_csv_trajectory(smoke_euroc / "mav0" / "state_groundtruth_estimate0" / "data.csv")
    t_gt, gt = read_euroc(smoke_euroc).gt
    assert traj.num_poses == len(t_gt)
    np.testing.assert_allclose(traj.positions_xyz, gt[:, :3], atol=1e-12)
    np.testing.assert_allclose(traj.orientations_quat_wxyz, gt[:, 3:7], atol=1e-12)
    np.testing.assert_allclose(traj.timestamps - EPOCH_NS / 1e9, (t_gt - EPOCH_NS) / 1e9, atol=5e-7)


@dataclass
class _WallWorld:
    model: Any
    truth: Any


def _wall_world() -> _WallWorld:
    """A 12 x 8 m wall with random grey texture whose face is the plane x = 5 m."""
    import mujoco

    from roman_sim.world.truth import Terrain, WorldTruth

    spec = mujoco.MjSpec()
    spec.visual.global_.offwidth, spec.visual.global_.offheight = 640, 480
    spec.visual.quality.shadowsize = 0
    spec.add_texture(
        name="dots",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_FLAT,
        rgb1=[0.1, 0.1, 0.1],
        rgb2=[0.1, 0.1, 0.1],
        markrgb=[0.9, 0.9, 0.9],
        mark=mujoco.mjtMark.mjMARK_RANDOM,
        random=0.5,
        width=128,
        height=128,
    )
    mat = spec.add_material(name="wall")
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "dots"
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 6, 4], pos=[5.05, 0, 1.0], material="wall")
    spec.worldbody.add_light(type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, dir=[1, 0, -0.3], pos=[0, 0, 10])
    truth = WorldTruth(objects=[], terrain=Terrain(size_x=40.0, size_y=40.0, heights=np.zeros((5, 5))))
    return _WallWorld(spec.compile(), truth)


def _disparity(left: np.ndarray, right: np.ndarray, window: tuple[slice, slice]) -> float:
    """The shift d (px) with right(u - d) = left(u) over ``window``: SSD at whole pixels, then refined."""
    import cv2
    from scipy.optimize import minimize_scalar

    L = left.astype(np.float32)[window]
    ys, xs = np.mgrid[window].astype(np.float32)
    R = right.astype(np.float32)

    def ssd(d: float) -> float:
        return float(np.mean((cv2.remap(R, xs - np.float32(d), ys, cv2.INTER_CUBIC) - L) ** 2))

    whole = min(range(0, 40), key=ssd)
    return float(minimize_scalar(ssd, bounds=(whole - 1, whole + 1), method="bounded", options={"xatol": 1e-4}).x)


def test_stereo_disparity_gives_the_rendered_depth(tmp_path: Path) -> None:
    from PIL import Image

    from roman_sim.core.config import validate_model
    from roman_sim.interop.euroc import EurocWriter
    from roman_sim.sim.robot import DrivenRun, RobotConfig, render_trajectory
    from roman_sim.sim.source import SensorRig

    cfg = validate_model(
        RobotConfig,
        {
            "name": "s",
            "camera": {"mount_height_m": 1.0, "mount_forward_m": 0.0, "depth_noise": {"enabled": False}},
            "stereo": {"baseline_m": 0.095},
        },
    )
    assert cfg.stereo is not None
    poses = np.stack([np.eye(4), make_T(t=[0.0, 0.3, 0.0])])  # the second frame 30 cm to the left
    run = DrivenRun(np.array([0.0, 1 / 6]), poses, poses)
    frames = list(render_trajectory(_wall_world(), cfg, 0, run, stereo=True))
    writer = EurocWriter(tmp_path / "s", "s", cfg.camera.intrinsics(), cfg.camera.T_body_cam())
    writer.set_rig(SensorRig(None, None, cfg.stereo.T_cam_cam2()))
    for f in frames:
        writer.write(f)
    writer.close()
    assert not (tmp_path / "s" / "mav0" / "imu0").exists()  # no IMU on this robot
    fx = yaml.safe_load((tmp_path / "s" / "mav0" / "cam0" / "sensor.yaml").read_text())["intrinsics"][0]
    chain = yaml.safe_load((tmp_path / "s" / "kalibr" / "camchain.yaml").read_text())
    baseline = -chain["cam1"]["T_cn_cnm1"][0][3]
    assert baseline == 0.095 and "T_cam_imu" not in chain["cam0"]
    window = (slice(120, 360), slice(160, 480))
    for f in frames:
        name = f"{EPOCH_NS + round(f.t * 1e9)}.png"
        left, right = (np.asarray(Image.open(tmp_path / "s" / "mav0" / c / "data" / name)) for c in ("cam0", "cam1"))
        depth = float(np.median(f.depth[window]))
        assert depth == pytest.approx(5.0, abs=1e-3)
        z = fx * baseline / _disparity(left, right, window)
        assert abs(z - depth) / depth < 0.01, (z, depth)
