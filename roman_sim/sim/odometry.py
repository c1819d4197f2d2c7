"""VIO-like drifting odometry.

Model (4-DoF drift: x, y, z, yaw; gravity keeps roll and pitch observable):

* The odometry frame is the robot's gravity-aligned start pose, so a VIO system starts
  at identity: ``T_world_odom = gravity_aligned(T_world_body[0])`` and
  ``T_odom_body[0]`` has zero x, y, z and yaw.
* Each step the true 4-DoF motion increment ``d = inv(G_{k-1}) @ G_k`` (``G`` the
  gravity-aligned true poses, so ``d`` is expressed in the previous heading frame) is
  corrupted and integrated: ``G'_k = G'_{k-1} @ d'``. With ``ds`` the distance travelled
  in the step (metres), the corrupted increment has

  - translation ``(1 + s) * t + n_t``, ``n_t ~ N(0, diag(sxy, sxy, sz)^2 * ds)``
    (``translation_sigma_m_per_sqrt_m``, ``z_sigma_m_per_sqrt_m``),
  - yaw ``yaw + b * ds + n_yaw``, ``n_yaw ~ N(0, syaw^2 * ds)``
    (``yaw_sigma_deg_per_sqrt_m``),

  where the scale error ``s ~ N(0, scale_error_std^2)`` and the yaw-rate bias
  ``b ~ N(0, yaw_bias_std_deg_per_m^2)`` are drawn once per run. Drift therefore is a
  random walk growing with the square root of distance (plus bias terms growing
  linearly), and yaw drift bends the later translation (position error grows faster).
* Roll and pitch are the true ones plus independent noise per frame, ``N(0, sigma^2)``
  clipped to ``+-roll_pitch_bound_deg``.

With every parameter zero, ``T_odom_body = inv(T_world_odom) @ T_world_body`` exactly
(up to float rounding).
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import SimError
from roman_sim.core.geometry import R_to_rpy, gravity_aligned, inv_T, make_T, rot_x, rot_y, rot_z, yaw_of
from roman_sim.core.registry import Registry

log = logging.getLogger(__name__)


class DriftConfig(StrictModel):
    """Parameters of the VIO-like drift model (see the module docstring)."""

    translation_sigma_m_per_sqrt_m: float = Field(0.05, ge=0.0, le=5.0)
    z_sigma_m_per_sqrt_m: float = Field(0.02, ge=0.0, le=5.0)
    yaw_sigma_deg_per_sqrt_m: float = Field(0.1, ge=0.0, le=30.0)
    scale_error_std: float = Field(0.005, ge=0.0, le=0.5)
    yaw_bias_std_deg_per_m: float = Field(0.005, ge=0.0, le=10.0)
    roll_pitch_sigma_deg: float = Field(0.2, ge=0.0, le=10.0)
    roll_pitch_bound_deg: float = Field(1.0, ge=0.0, le=10.0)


DRIFT_PRESETS: Registry[DriftConfig] = Registry("drift preset")
DRIFT_PRESETS.register(
    "zero",
    DriftConfig(
        translation_sigma_m_per_sqrt_m=0,
        z_sigma_m_per_sqrt_m=0,
        yaw_sigma_deg_per_sqrt_m=0,
        scale_error_std=0,
        yaw_bias_std_deg_per_m=0,
        roll_pitch_sigma_deg=0,
        roll_pitch_bound_deg=0,
    ),
)
DRIFT_PRESETS.register(
    "good",
    DriftConfig(
        translation_sigma_m_per_sqrt_m=0.025,
        z_sigma_m_per_sqrt_m=0.01,
        yaw_sigma_deg_per_sqrt_m=0.05,
        scale_error_std=0.002,
        yaw_bias_std_deg_per_m=0.002,
        roll_pitch_sigma_deg=0.1,
        roll_pitch_bound_deg=0.5,
    ),
)
DRIFT_PRESETS.register("typical", DriftConfig())
DRIFT_PRESETS.register(
    "poor",
    DriftConfig(
        translation_sigma_m_per_sqrt_m=0.15,
        z_sigma_m_per_sqrt_m=0.06,
        yaw_sigma_deg_per_sqrt_m=0.3,
        scale_error_std=0.015,
        yaw_bias_std_deg_per_m=0.015,
        roll_pitch_sigma_deg=0.4,
        roll_pitch_bound_deg=2.0,
    ),
)


def resolve_drift(drift: str | DriftConfig) -> DriftConfig:
    """A ``DriftConfig`` from a preset name (``good``, ``typical``, ``poor``, ``zero``) or itself."""
    if isinstance(drift, DriftConfig):
        return drift
    return DRIFT_PRESETS.get(drift)


class DriftModel:
    """Streaming drift model: feed true body poses in order, get drifted odometry poses.

    Args:
        cfg: drift parameters.
        rng: seeded generator (``seeding.child_rng(seed, "drift", robot_name)``).
    """

    def __init__(self, cfg: DriftConfig, rng: np.random.Generator) -> None:
        self.cfg = cfg
        self.rng = rng
        self.scale_error = float(rng.normal(0.0, cfg.scale_error_std)) if cfg.scale_error_std > 0 else 0.0
        bias = float(rng.normal(0.0, cfg.yaw_bias_std_deg_per_m)) if cfg.yaw_bias_std_deg_per_m > 0 else 0.0
        self.yaw_bias_rad_per_m = np.radians(bias)
        self.T_world_odom: NDArray[np.float64] | None = None
        self._prev_true: NDArray[np.float64] | None = None
        self._odom_G: NDArray[np.float64] = np.eye(4)

    def step(self, T_world_body: NDArray[np.float64]) -> NDArray[np.float64]:
        """Drifted ``T_odom_body`` for the next true pose (4x4)."""
        T = np.asarray(T_world_body, dtype=np.float64)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise SimError(f"odometry: T_world_body must be a finite 4x4 pose, got shape {T.shape}")
        G = gravity_aligned(T)
        if self._prev_true is None:
            self.T_world_odom = G
            self._odom_G = np.eye(4)
        else:
            self._odom_G = self._odom_G @ self._noisy_increment(inv_T(self._prev_true) @ G)
        self._prev_true = G
        return self._odom_G @ self._tilt(inv_T(G) @ T)

    def _noisy_increment(self, d: NDArray[np.float64]) -> NDArray[np.float64]:
        c = self.cfg
        t = d[:3, 3]
        ds = float(np.linalg.norm(t))
        sig = np.array([c.translation_sigma_m_per_sqrt_m] * 2 + [c.z_sigma_m_per_sqrt_m]) * np.sqrt(ds)
        t_noisy = (1.0 + self.scale_error) * t + self.rng.standard_normal(3) * sig
        yaw_noise = np.radians(c.yaw_sigma_deg_per_sqrt_m) * np.sqrt(ds) * self.rng.standard_normal()
        yaw = yaw_of(d) + self.yaw_bias_rad_per_m * ds + yaw_noise
        return make_T(rot_z(yaw), t_noisy)

    def _tilt(self, R_tilt_T: NDArray[np.float64]) -> NDArray[np.float64]:
        """Add bounded roll/pitch noise to the pure-tilt part (yaw already removed)."""
        c = self.cfg
        if c.roll_pitch_sigma_deg <= 0:
            return make_T(R_tilt_T[:3, :3])
        bound = np.radians(c.roll_pitch_bound_deg)
        dr, dp = np.clip(self.rng.normal(0.0, np.radians(c.roll_pitch_sigma_deg), 2), -bound, bound)
        roll, pitch, _ = R_to_rpy(R_tilt_T[:3, :3])
        return make_T(rot_y(pitch + dp) @ rot_x(roll + dr))


def drift_trajectory(
    T_world_body: NDArray[np.float64], cfg: DriftConfig, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Drifted odometry (N, 4, 4) for a whole true trajectory (N, 4, 4)."""
    model = DriftModel(cfg, rng)
    return np.stack([model.step(T) for T in np.asarray(T_world_body, dtype=np.float64).reshape(-1, 4, 4)])
