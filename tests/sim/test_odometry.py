"""Drift model: zero drift is exact, statistics grow with distance as configured, bounded tilt."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import R_to_rpy, gravity_aligned, inv_T, make_T, rpy_to_R, wrap_angle, yaw_of
from roman_sim.sim.odometry import DRIFT_PRESETS, DriftConfig, drift_trajectory, resolve_drift
from roman_sim.sim.robot import RobotConfig


def _wavy_trajectory(n: int = 120, step: float = 0.5) -> np.ndarray:
    """Poses along a curvy line with terrain-like roll/pitch, starting away from the origin."""
    out = []
    for k in range(n):
        yaw = 0.6 + 0.3 * np.sin(k / 15)
        R = rpy_to_R(0.05 * np.sin(k / 7), 0.04 * np.cos(k / 9), yaw)
        out.append(make_T(R, [3.0 + k * step * np.cos(0.6), -2.0 + k * step * np.sin(0.6), 0.2 * np.sin(k / 10)]))
    return np.stack(out)


def test_zero_drift_equals_truth_in_the_odometry_frame() -> None:
    T_wb = _wavy_trajectory()
    T_ob = drift_trajectory(T_wb, resolve_drift("zero"), np.random.default_rng(0))
    T_wo = gravity_aligned(T_wb[0])
    for a, b in zip(T_ob, T_wb):
        np.testing.assert_allclose(a, inv_T(T_wo) @ b, atol=1e-9)


def test_odometry_starts_at_identity_in_x_y_z_yaw() -> None:
    T_ob = drift_trajectory(_wavy_trajectory(5), resolve_drift("poor"), np.random.default_rng(3))
    np.testing.assert_allclose(T_ob[0][:3, 3], 0.0, atol=1e-12)
    assert yaw_of(T_ob[0]) == pytest.approx(0.0, abs=1e-12)


def _straight(n: int, step: float) -> np.ndarray:
    return np.stack([make_T(t=[k * step, 0.0, 0.0]) for k in range(n)])


def test_random_walk_grows_with_sqrt_distance() -> None:
    cfg = DriftConfig(
        translation_sigma_m_per_sqrt_m=0.1,
        z_sigma_m_per_sqrt_m=0.05,
        yaw_sigma_deg_per_sqrt_m=0.0,
        scale_error_std=0.0,
        yaw_bias_std_deg_per_m=0.0,
        roll_pitch_sigma_deg=0.0,
    )
    T_wb = _straight(21, 2.0)  # 40 m
    errs = np.array(
        [drift_trajectory(T_wb, cfg, np.random.default_rng(s))[:, :3, 3] - T_wb[:, :3, 3] for s in range(400)]
    )
    for idx, dist in ((5, 10.0), (20, 40.0)):
        std = errs[:, idx].std(axis=0)
        assert std[0] == pytest.approx(0.1 * np.sqrt(dist), rel=0.15)
        assert std[1] == pytest.approx(0.1 * np.sqrt(dist), rel=0.15)
        assert std[2] == pytest.approx(0.05 * np.sqrt(dist), rel=0.15)


def test_yaw_drift_and_bounded_roll_pitch() -> None:
    cfg = DriftConfig(
        translation_sigma_m_per_sqrt_m=0.0,
        z_sigma_m_per_sqrt_m=0.0,
        yaw_sigma_deg_per_sqrt_m=0.5,
        scale_error_std=0.0,
        yaw_bias_std_deg_per_m=0.0,
        roll_pitch_sigma_deg=0.5,
        roll_pitch_bound_deg=1.0,
    )
    T_wb = _straight(21, 2.0)  # 40 m
    yaw_err, tilt = [], []
    for s in range(400):
        T_ob = drift_trajectory(T_wb, cfg, np.random.default_rng(s))
        yaw_err.append(yaw_of(T_ob[-1]))
        tilt.append([R_to_rpy(T[:3, :3])[:2] for T in T_ob])
    assert np.degrees(np.std(yaw_err)) == pytest.approx(0.5 * np.sqrt(40.0), rel=0.15)
    tilt = np.degrees(np.abs(np.array(tilt)))
    assert tilt.max() <= 1.0 + 1e-9 and tilt.max() > 0.9


def test_presets_order_and_typical_is_about_one_percent() -> None:
    T_wb = _straight(51, 2.0)  # 100 m
    final = {}
    for name in ("good", "typical", "poor"):
        errs = [
            np.linalg.norm(
                drift_trajectory(T_wb, resolve_drift(name), np.random.default_rng(s))[-1, :3, 3] - T_wb[-1, :3, 3]
            )
            for s in range(50)
        ]
        final[name] = float(np.sqrt(np.mean(np.square(errs))))
    assert final["good"] < final["typical"] < final["poor"]
    assert 0.4 < final["typical"] < 2.0  # about 1 % of 100 m


def test_scale_bias_makes_odometry_long() -> None:
    cfg = DriftConfig(
        translation_sigma_m_per_sqrt_m=0,
        z_sigma_m_per_sqrt_m=0,
        yaw_sigma_deg_per_sqrt_m=0,
        scale_error_std=0.05,
        yaw_bias_std_deg_per_m=0,
        roll_pitch_sigma_deg=0,
    )
    rng = np.random.default_rng(2)
    s = np.random.default_rng(2).normal(0.0, 0.05)
    T_ob = drift_trajectory(_straight(11, 1.0), cfg, rng)
    assert T_ob[-1][0, 3] == pytest.approx(10.0 * (1 + s))


def test_unknown_preset_lists_valid_names() -> None:
    with pytest.raises(ConfigError, match="good.*poor.*typical"):
        resolve_drift("excellent")
    with pytest.raises(ConfigError, match="drift"):
        validate_model(RobotConfig, {"drift": "excellent"})
    assert set(DRIFT_PRESETS.names()) >= {"good", "typical", "poor"}


def test_yaw_wraps_correctly_on_u_turns() -> None:
    T_wb = np.stack(
        [make_T(rpy_to_R(0, 0, float(wrap_angle(0.2 * k))), [np.cos(0.2 * k), np.sin(0.2 * k), 0]) for k in range(70)]
    )
    T_ob = drift_trajectory(T_wb, resolve_drift("zero"), np.random.default_rng(0))
    np.testing.assert_allclose(T_ob[-1], inv_T(gravity_aligned(T_wb[0])) @ T_wb[-1], atol=1e-9)
