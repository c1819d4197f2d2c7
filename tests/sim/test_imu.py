"""The IMU: readings against hand-computed motion, the noise model's figures, rate checks, seeding.

Readings are checked on a circle driven at constant speed, where the body rates and the
specific force are known in closed form; the noise against Kalibr's discrete model
(white-noise std ``sigma * sqrt(rate)``, bias steps ``sigma_b / sqrt(rate)``). Integration
of the readings back to the trajectory is checked on the exported smoke drive
(``tests/interop/test_export_euroc.py``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import make_T, rot_z
from roman_sim.sim.imu import IMU_PRESETS, ImuConfig, SmoothTrajectory, imu_readings, sample_times
from roman_sim.sim.robot import RobotConfig

G = 9.81


def _circle(radius: float, speed: float, duration: float, rate_hz: float = 6.0):
    """Frame times and poses driving a horizontal circle counter-clockwise, body x along the velocity."""
    t = np.arange(0.0, duration + 1e-9, 1.0 / rate_hz)
    w = speed / radius
    xyz = np.column_stack([radius * np.cos(w * t), radius * np.sin(w * t), np.ones_like(t)])
    poses = np.stack([make_T(rot_z(w * s + np.pi / 2), p) for s, p in zip(t, xyz)])
    return t, poses


def test_readings_on_a_circle_are_the_closed_form_ones() -> None:
    """Turning left at v = 1 m/s on r = 5 m: gyro (0, 0, v/r), accel (0, v^2/r, g) in FLU, at every IMU time."""
    t, poses = _circle(5.0, 1.0, 30.0)
    traj = SmoothTrajectory(t, poses)
    np.testing.assert_allclose(traj.poses(t), poses, atol=1e-12)  # the spline passes through every frame pose
    imu = imu_readings(traj, t, 6.0, ImuConfig(rate_hz=600, noise=False), np.random.default_rng(0))
    assert imu.rate_hz == 600 and len(imu.t) == 100 * (len(t) - 1) + 1 and not imu.noisy
    inner = (imu.t > 3.0) & (imu.t < 27.0)  # away from the spline's end conditions
    np.testing.assert_allclose(imu.gyro[inner], np.tile([0.0, 0.0, 0.2], (inner.sum(), 1)), atol=2e-4)
    np.testing.assert_allclose(imu.accel[inner], np.tile([0.0, 0.2, G], (inner.sum(), 1)), atol=2e-3)
    np.testing.assert_allclose(traj.velocity(t[10:-10]), (poses[10:-10, :3, 0]) * 1.0, atol=1e-4)


def test_sample_times_fall_on_every_frame() -> None:
    t = np.array([0.0, 1 / 6, 2 / 6, 3 / 6])
    s = sample_times(t, 4)
    assert len(s) == 13 and np.all(s[::4] == t)
    np.testing.assert_allclose(np.diff(s), 1 / 24, atol=1e-15)


@pytest.mark.parametrize("preset", ["d455", "euroc"])
def test_noise_follows_the_continuous_time_model(preset: str) -> None:
    """White noise std sigma * sqrt(rate) and bias steps sigma_b / sqrt(rate), within 3 %."""
    t = np.array([0.0, 10.0, 20.0])
    poses = np.stack([np.eye(4)] * 3)  # at rest: clean readings are (0, 0, 0) and (0, 0, g)
    traj = SmoothTrajectory(t, poses)
    cfg = ImuConfig(preset=preset, rate_hz=1000.0)
    imu = imu_readings(traj, t, 0.1, cfg, np.random.default_rng(7))
    n = IMU_PRESETS.get(preset)
    rate = 1000.0
    white_g = imu.gyro - imu.gyro_bias
    white_a = imu.accel - imu.accel_bias - [0.0, 0.0, G]
    assert np.std(white_g) == pytest.approx(n.gyroscope_noise_density * math.sqrt(rate), rel=0.03)
    assert np.std(white_a) == pytest.approx(n.accelerometer_noise_density * math.sqrt(rate), rel=0.03)
    assert np.std(np.diff(imu.gyro_bias, axis=0)) == pytest.approx(n.gyroscope_random_walk / math.sqrt(rate), rel=0.03)
    assert np.std(np.diff(imu.accel_bias, axis=0)) == pytest.approx(
        n.accelerometer_random_walk / math.sqrt(rate), rel=0.03
    )
    assert np.all(imu.gyro_bias[0] == 0) and np.all(imu.accel_bias[0] == 0)
    again = imu_readings(traj, t, 0.1, cfg, np.random.default_rng(7))
    np.testing.assert_array_equal(again.accel, imu.accel)


def test_d455_preset_is_the_bmi055_data_sheet() -> None:
    """0.014 deg/s/sqrt(Hz) and 150 ug/sqrt(Hz), in Kalibr's SI units."""
    n = IMU_PRESETS.get("d455")
    assert n.gyroscope_noise_density == pytest.approx(0.014 * np.pi / 180)
    assert n.accelerometer_noise_density == pytest.approx(150e-6 * 9.80665)
    e = IMU_PRESETS.get("euroc")
    assert (e.gyroscope_noise_density, e.accelerometer_random_walk) == (1.6968e-04, 3.0e-3)


def test_rate_must_be_a_whole_multiple_of_the_frame_rate() -> None:
    ok = validate_model(RobotConfig, {"imu": {"rate_hz": 198}})
    assert ok.imu is not None and ok.imu.per_frame(ok.rate_hz) == 33
    assert validate_model(RobotConfig, {"imu": {}}).imu.per_frame(6.0) == 33  # 200 Hz nominal -> 198 Hz
    assert validate_model(RobotConfig, {"rate_hz": 10, "imu": {"rate_hz": 200}}).imu is not None
    for data in ({"imu": {"rate_hz": 200}}, {"imu": {"rate_hz": 3}}, {"rate_hz": 7, "imu": {"rate_hz": 200}}):
        with pytest.raises(ConfigError) as err:
            validate_model(RobotConfig, data, source="robot")
        msg = str(err.value)
        assert "imu.rate_hz" in msg and "whole multiple of the frame rate" in msg and "\n" not in msg
    for baseline in (0, -0.1):
        with pytest.raises(ConfigError, match=r"stereo\.baseline_m: Input should be greater than 0"):
            validate_model(RobotConfig, {"stereo": {"baseline_m": baseline}}, source="robot")
    with pytest.raises(ConfigError, match="unknown IMU preset 'bmi'"):
        validate_model(RobotConfig, {"imu": {"preset": "bmi"}})


def test_absent_sensors_leave_the_dumped_configuration_as_it_was() -> None:
    """A robot without an IMU or second camera dumps no ``imu``/``stereo`` key (run hashes unchanged)."""
    plain = validate_model(RobotConfig, {"name": "a"}).model_dump(mode="json")
    assert "imu" not in plain and "stereo" not in plain
    full = validate_model(RobotConfig, {"name": "a", "imu": {}, "stereo": {}}).model_dump(mode="json")
    assert full["imu"]["preset"] == "d455" and full["stereo"] == {"baseline_m": 0.095}
    assert validate_model(RobotConfig, full) == validate_model(RobotConfig, {"name": "a", "imu": {}, "stereo": {}})


def test_an_imu_and_a_second_camera_change_no_other_stream() -> None:
    """Same seed: the same paths, odometry and rendered depth (noise included) with or without them;
    the IMU's own noise is reproducible and differs between robots."""
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.sim.source import robot_sources
    from roman_sim.world import generate

    small = ["robots.0.camera.width=32", "robots.0.camera.height=24", "robots.1.camera.width=32"]
    small += ["robots.1.camera.height=24", "robots.0.max_duration_s=2", "robots.1.max_duration_s=2"]
    plain = load_scenario("smoke", small)
    sensors = ["robots.0.imu.preset=d455", "robots.0.stereo.baseline_m=0.2", "robots.1.imu.preset=d455"]
    fitted = load_scenario("smoke", [*small, *sensors])
    world = generate(plain.world.spec(), plain.seed)
    a = robot_sources(world, plain.robots, plain.seed, rgb=True)
    b = [s.with_stereo() for s in robot_sources(world, fitted.robots, fitted.seed, rgb=True)]
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x.run.T_odom_body, y.run.T_odom_body)
        np.testing.assert_array_equal(x.run.T_world_body, y.run.T_world_body)
        for f, g in zip(x.frames([0, 3]), y.frames([0, 3])):
            np.testing.assert_array_equal(f.depth, g.depth)
            np.testing.assert_array_equal(f.rgb, g.rgb)
    frames = list(b[0].frames([1]))
    assert frames[0].rgb_right is not None and not np.array_equal(frames[0].rgb_right, frames[0].rgb)
    assert list(b[1].frames([1]))[0].rgb_right is None  # robot b has no second camera
    ia, ib = b[0].rig().imu, b[1].rig().imu
    assert ia is not None and ib is not None and ia.noisy
    np.testing.assert_array_equal(ia.gyro, b[0].rig().imu.gyro)
    assert not np.allclose(ia.gyro_bias[-1], ib.gyro_bias[-1])
