"""Depth noise model: range-squared std, quantisation, edges, max range, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.sim.camera import DepthNoiseConfig
from roman_sim.sim.noise import apply_depth_noise, depth_edges


def test_std_grows_with_range_squared() -> None:
    cfg = DepthNoiseConfig(quantum_m=0.0)
    for z, expected in ((4.0, 0.08), (2.0, 0.02)):
        d = np.full((120, 160), z, dtype=np.float32)
        out = apply_depth_noise(d, cfg, 10.0, np.random.default_rng(1))
        inner = out[2:-2, 2:-2]
        assert np.all(inner > 0)
        assert np.std(inner - z) == pytest.approx(expected, rel=0.05)
        assert abs(np.mean(inner - z)) < 0.005


def test_quantisation_max_range_and_invalid_stay_invalid() -> None:
    d = np.full((20, 20), 3.0, dtype=np.float32)
    d[:, 10:] = 9.0
    d[0, 0] = 0.0
    out = apply_depth_noise(d, DepthNoiseConfig(quantum_m=0.01), 7.5, np.random.default_rng(0))
    assert np.all(out[:, 12:] == 0.0)  # beyond max range
    assert out[0, 0] == 0.0
    v = out[out > 0].astype(np.float64)
    np.testing.assert_allclose(v / 0.01, np.round(v / 0.01), atol=1e-3)


def test_depth_edges_are_invalidated() -> None:
    d = np.full((10, 10), 2.0, dtype=np.float32)
    d[:, 5:] = 5.0
    e = depth_edges(d, 0.3)
    assert e[:, 4:6].all() and not e[:, :3].any() and not e[:, 7:].any()
    out = apply_depth_noise(d, DepthNoiseConfig(), 7.5, np.random.default_rng(0))
    assert np.all(out[:, 4:6] == 0) and np.all(out[1:-1, 1:3] > 0)


def test_disabled_noise_only_truncates_and_same_seed_same_output() -> None:
    d = np.linspace(0.5, 9.0, 100, dtype=np.float32).reshape(10, 10)
    clean = apply_depth_noise(d, DepthNoiseConfig(enabled=False), 7.5, np.random.default_rng(0))
    np.testing.assert_array_equal(clean, np.where(d <= 7.5, d, 0))
    a = apply_depth_noise(d, DepthNoiseConfig(), 7.5, np.random.default_rng(5))
    b = apply_depth_noise(d, DepthNoiseConfig(), 7.5, np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)


def test_fast_filter_matches_scipy() -> None:
    from scipy.ndimage import maximum_filter, minimum_filter

    from roman_sim.sim.noise import _filter3

    img = np.random.default_rng(1).uniform(0, 5, (13, 17)).astype(np.float32)
    np.testing.assert_array_equal(_filter3(img, np.maximum), maximum_filter(img, size=3, mode="nearest"))
    np.testing.assert_array_equal(_filter3(img, np.minimum), minimum_filter(img, size=3, mode="nearest"))


def test_noisy_readings_never_exceed_max_range() -> None:
    depth = np.full((40, 40), 7.49, dtype=np.float32)  # just inside the range: noise pushes half out
    out = apply_depth_noise(depth, DepthNoiseConfig(), 7.5, np.random.default_rng(0))
    assert out.max() <= 7.5
    assert 0.2 < np.mean(out == 0) < 0.8  # those measured beyond the range are invalid
