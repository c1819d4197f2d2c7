"""An IMU on the robot body: gyroscope and accelerometer readings consistent with the true trajectory.

The true poses come one per frame (``rate_hz``, 6 Hz by default); an IMU samples far faster.
``SmoothTrajectory`` makes the frame poses continuous: positions by a C2 cubic spline
(scipy's ``CubicSpline``), rotations by scipy's ``RotationSpline`` (also C2), both through
every frame pose; both are differentiated analytically, so readings exist at any time.

The IMU sits at the body origin with the body's axes (FLU), so ``T_body_imu`` is the
identity and EuRoC's body frame is the IMU frame. At time ``t``, with ``R = R_world_body``:

* gyroscope ``w = omega_body(t) + b_g(t) + n_g``, the body-frame angular rate;
* accelerometer ``a = R^T (a_world(t) - g_world) + b_a(t) + n_a``, the specific force, with
  ``g_world = (0, 0, -gravity_mps2)`` (a robot at rest reads ``+gravity`` on body z).

Noise follows the continuous-time model Kalibr and the VIO systems use: a white-noise
density ``sigma`` (per sqrt(Hz)) gives discrete samples ``N(0, sigma^2 * rate)``; a bias
random walk ``sigma_b`` gives ``b_{k+1} = b_k + N(0, sigma_b^2 / rate)``, starting at 0.
Integrating noise-free readings (``noise: false``) from the first true state (pose and
``SmoothTrajectory.velocity``) gives the spline back, so the frame poses.

The IMU rate is a whole multiple of the frame rate: samples fall on every frame time and
evenly between them. Noise comes from its own stream (``imu`` and the robot name under the
scenario seed), so adding an IMU changes no other random stream.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import SimError
from roman_sim.core.registry import Registry

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline
    from scipy.spatial.transform import RotationSpline

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
#: Standard gravity (m/s^2), what a data sheet's "g" means.
G0 = 9.80665


class ImuNoise(StrictModel):
    """An IMU's noise, in Kalibr's units (continuous time).

    Attributes:
        gyroscope_noise_density: rad/s/sqrt(Hz) (gyro white noise).
        gyroscope_random_walk: rad/s^2/sqrt(Hz) (gyro bias diffusion).
        accelerometer_noise_density: m/s^2/sqrt(Hz) (accel white noise).
        accelerometer_random_walk: m/s^3/sqrt(Hz) (accel bias diffusion).
        rate_hz: the device's nominal rate (the default IMU rate rounds it to a multiple of the frame rate).
        device: what the figures describe.
    """

    gyroscope_noise_density: float = Field(..., ge=0.0, le=1.0)
    gyroscope_random_walk: float = Field(..., ge=0.0, le=1.0)
    accelerometer_noise_density: float = Field(..., ge=0.0, le=10.0)
    accelerometer_random_walk: float = Field(..., ge=0.0, le=10.0)
    rate_hz: float = Field(200.0, gt=0.0, le=10000.0)
    device: str = ""


IMU_PRESETS: Registry[ImuNoise] = Registry("IMU preset")

#: Intel RealSense D455's IMU, a Bosch BMI055. White noise from Bosch's BMI055 data sheet
#: (BST-BMI055-DS000-08, rev. 1.2, 2014: gyroscope rate noise density 0.014 deg/s/sqrt(Hz),
#: accelerometer output noise density 150 ug/sqrt(Hz), the values tabulated again in
#: blog.csdn.net/dongqingyueyue/article/details/103731233). The data sheet gives no bias
#: random walk; the preset takes the Allan-deviation figures rpng/open_vins publishes for a
#: D455 (config/rs_d455/kalibr_imu_chain.yaml, "values from allan plots"). Rate: the
#: D455 driver's 200 Hz gyroscope setting.
IMU_PRESETS.register(
    "d455",
    ImuNoise(
        gyroscope_noise_density=math.radians(0.014),
        gyroscope_random_walk=1.1106223553679963e-06,
        accelerometer_noise_density=150e-6 * G0,
        accelerometer_random_walk=4.132785219723178e-05,
        rate_hz=200.0,
        device="Intel RealSense D455 (Bosch BMI055)",
    ),
)
#: EuRoC MAV's ADIS16448 at 200 Hz, as the data set's ``imu0/sensor.yaml`` states it.
IMU_PRESETS.register(
    "euroc",
    ImuNoise(
        gyroscope_noise_density=1.6968e-04,
        gyroscope_random_walk=1.9393e-05,
        accelerometer_noise_density=2.0e-3,
        accelerometer_random_walk=3.0e-3,
        rate_hz=200.0,
        device="EuRoC MAV VI-Sensor (ADIS16448)",
    ),
)


class ImuConfig(StrictModel):
    """A robot's IMU (module docstring): its noise preset or figures, rate and gravity.

    ``rate_hz`` must be a whole multiple of the robot's frame rate (``RobotConfig`` checks
    it); None takes the preset's nominal rate rounded to the nearest multiple (198 Hz for
    200 Hz at 6 Hz frames). ``noise: false`` draws neither white noise nor bias.
    """

    preset: str | ImuNoise = "d455"
    rate_hz: float | None = Field(None, gt=0.0, le=10000.0)
    noise: bool = True
    gravity_mps2: float = Field(9.81, gt=0.0, le=100.0)

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, v: str | ImuNoise) -> str | ImuNoise:
        if isinstance(v, str) and v not in IMU_PRESETS:
            raise ValueError(f"unknown IMU preset {v!r} (valid: {', '.join(IMU_PRESETS.names())})")
        return v

    def noise_model(self) -> ImuNoise:
        """The resolved noise figures."""
        return IMU_PRESETS.get(self.preset) if isinstance(self.preset, str) else self.preset

    def per_frame(self, frame_rate_hz: float) -> int:
        """IMU samples per frame interval (the rate over the frame rate, a whole number >= 1).

        Raises: ValueError naming ``imu.rate_hz`` when the rate is not a whole multiple.
        """
        if self.rate_hz is None:
            return max(1, round(self.noise_model().rate_hz / frame_rate_hz))
        ratio = self.rate_hz / frame_rate_hz
        n = round(ratio)
        if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
            lo, hi = max(1, math.floor(ratio)), max(1, math.floor(ratio)) + 1
            raise ValueError(
                f"imu.rate_hz: {self.rate_hz:g} Hz is not a whole multiple of the frame rate "
                f"{frame_rate_hz:g} Hz (rate_hz); allowed: k * {frame_rate_hz:g} Hz, "
                f"e.g. {lo * frame_rate_hz:g} or {hi * frame_rate_hz:g}"
            )
        return n


class SmoothTrajectory:
    """A C2 trajectory through poses at times ``t`` (module docstring), with analytic derivatives.

    Args:
        t: (N,) strictly increasing times (s), N >= 2.
        T_world_body: (N, 4, 4) poses.

    Raises: SimError for fewer than two poses or times that do not increase.
    """

    def __init__(self, t: F64, T_world_body: F64) -> None:
        from scipy.interpolate import CubicSpline
        from scipy.spatial.transform import Rotation, RotationSpline

        t = np.asarray(t, dtype=np.float64)
        T = np.asarray(T_world_body, dtype=np.float64)
        if len(t) < 2 or np.any(np.diff(t) <= 0):
            raise SimError("a smooth trajectory needs at least two poses at increasing times")
        self.t0, self.t1 = float(t[0]), float(t[-1])
        self._p: CubicSpline = CubicSpline(t, T[:, :3, 3], axis=0)
        self._r: RotationSpline = RotationSpline(t, Rotation.from_matrix(T[:, :3, :3]))

    def _check(self, t: F64) -> F64:
        t = np.asarray(t, dtype=np.float64)
        if t.size and (t.min() < self.t0 - 1e-9 or t.max() > self.t1 + 1e-9):
            raise SimError(f"times outside the trajectory's [{self.t0:g}, {self.t1:g}] s")
        return np.clip(t, self.t0, self.t1)

    def poses(self, t: F64) -> F64:
        """(M, 4, 4) ``T_world_body`` at times ``t`` (M,)."""
        t = self._check(t)
        out = np.tile(np.eye(4), (len(t), 1, 1))
        out[:, :3, :3] = self._r(t).as_matrix()
        out[:, :3, 3] = self._p(t)
        return out

    def velocity(self, t: F64) -> F64:
        """(M, 3) world-frame velocity (m/s)."""
        return np.asarray(self._p(self._check(t), 1), dtype=np.float64)

    def acceleration(self, t: F64) -> F64:
        """(M, 3) world-frame acceleration (m/s^2), gravity not included."""
        return np.asarray(self._p(self._check(t), 2), dtype=np.float64)

    def angular_velocity_body(self, t: F64) -> F64:
        """(M, 3) body-frame angular rate (rad/s): ``R^T dR/dt`` as a vector."""
        return np.asarray(self._r(self._check(t), 1), dtype=np.float64)


def sample_times(t_frames: F64, per_frame: int) -> F64:
    """IMU times: every frame time and ``per_frame - 1`` evenly spaced times in each interval."""
    t = np.asarray(t_frames, dtype=np.float64)
    k = np.arange(per_frame, dtype=np.float64) / per_frame
    inner = (t[:-1, None] + k[None, :] * np.diff(t)[:, None]).reshape(-1)
    return np.concatenate([inner, t[-1:]])


@dataclass(frozen=True)
class ImuData:
    """A robot's IMU readings and the true biases behind them.

    Attributes:
        t: (M,) times (s), on the frame clock.
        gyro: (M, 3) angular rate readings (rad/s), body (IMU) frame.
        accel: (M, 3) specific-force readings (m/s^2), body (IMU) frame.
        gyro_bias: (M, 3) true gyroscope bias in each reading.
        accel_bias: (M, 3) true accelerometer bias in each reading.
        rate_hz: the sampling rate.
        noise: the IMU's noise figures (what its calibration files state).
        noisy: whether noise and bias were drawn (False: the readings are exact).
        gravity_mps2: the gravity magnitude used.
    """

    t: F64
    gyro: F64
    accel: F64
    gyro_bias: F64
    accel_bias: F64
    rate_hz: float
    noise: ImuNoise
    noisy: bool
    gravity_mps2: float


def _random_walk(rng: np.random.Generator, n: int, sigma: float, rate_hz: float) -> F64:
    steps = rng.standard_normal((n, 3)) * (sigma / math.sqrt(rate_hz))
    steps[0] = 0.0
    return np.cumsum(steps, axis=0)


def imu_readings(
    traj: SmoothTrajectory, t_frames: F64, frame_rate_hz: float, cfg: ImuConfig, rng: np.random.Generator
) -> ImuData:
    """The IMU readings along ``traj`` (module docstring), sampled between the frame times ``t_frames``.

    Draws from ``rng`` (bias walks, then white noise; gyroscope, then accelerometer) only when
    ``cfg.noise`` is on.
    """
    n = cfg.per_frame(frame_rate_hz)
    rate = n * frame_rate_hz
    t = sample_times(t_frames, n)
    R = traj.poses(t)[:, :3, :3]
    g_world = np.array([0.0, 0.0, -cfg.gravity_mps2])
    gyro = traj.angular_velocity_body(t)
    accel = np.einsum("nji,nj->ni", R, traj.acceleration(t) - g_world)
    model = cfg.noise_model()
    if not cfg.noise:
        zeros = np.zeros_like(gyro)
        return ImuData(t, gyro, accel, zeros, zeros.copy(), rate, model, False, cfg.gravity_mps2)
    bg = _random_walk(rng, len(t), model.gyroscope_random_walk, rate)
    ba = _random_walk(rng, len(t), model.accelerometer_random_walk, rate)
    ng = rng.standard_normal(gyro.shape) * (model.gyroscope_noise_density * math.sqrt(rate))
    na = rng.standard_normal(accel.shape) * (model.accelerometer_noise_density * math.sqrt(rate))
    log.debug("IMU: %d readings at %g Hz (%s)", len(t), rate, model.device)
    return ImuData(t, gyro + bg + ng, accel + ba + na, bg, ba, rate, model, True, cfg.gravity_mps2)
