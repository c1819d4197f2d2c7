"""Registration wrappers: recovery, degeneracy reasons, tilt check, batched Kabsch."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align.registration import degeneracy, estimate_transform, kabsch_batch, tilt_ok
from roman_sim.core.geometry import arun, make_T, pose_4dof, pose_error, rpy_to_R, transform_points


def test_recovers_6dof_and_4dof() -> None:
    rng = np.random.default_rng(0)
    src = rng.uniform(-10, 10, (12, 3))
    T6 = make_T(rpy_to_R(0.1, -0.2, 2.0), [1.0, 2.0, 3.0])
    T, why = estimate_transform(src, transform_points(T6, src))
    assert why is None and max(pose_error(T, T6)) < 1e-9
    T4 = pose_4dof(3.0, -1.0, 0.5, -2.5)
    T, why = estimate_transform(src, transform_points(T4, src) + rng.normal(0, 0.01, src.shape), dof=4)
    assert why is None and pose_error(T, T4)[0] < 0.01 and pose_error(T, T4)[1] < 0.05
    np.testing.assert_allclose(T[2, :3], [0, 0, 1], atol=1e-12)  # yaw only


def test_weights_down_weight_an_outlier() -> None:
    rng = np.random.default_rng(1)
    src = rng.uniform(-5, 5, (8, 3))
    dst = src.copy()
    dst[0] += [3.0, 0, 0]
    w = np.ones(8)
    w[0] = 0.0
    T, _ = estimate_transform(src, dst, w)
    assert max(pose_error(T, np.eye(4))) < 1e-9
    T_unweighted, _ = estimate_transform(src, dst)
    assert pose_error(T_unweighted, np.eye(4))[1] > 0.1


@pytest.mark.parametrize(
    "pts,dof,expect",
    [
        (np.zeros((2, 3)), 6, "fewer than 3"),
        (np.ones((5, 3)), 6, "coincident"),
        (np.outer(np.arange(5.0), [1.0, 2.0, 0.5]), 6, "collinear"),
        (np.array([[0, 0, 0.0], [0, 0, 1], [0, 0, 2]]), 4, "coincident"),
        (np.array([[0, 0, 0.0], [1, np.nan, 0], [0, 1, 0]]), 6, "non-finite"),
    ],
)
def test_degenerate_inputs_give_reasons(pts: np.ndarray, dof: int, expect: str) -> None:
    assert expect in (degeneracy(pts, dof) or "")
    T, why = estimate_transform(pts, pts, dof=dof)
    assert T is None and expect in why


def test_collinear_is_fine_for_4dof() -> None:
    pts = np.outer(np.arange(5.0), [1.0, 2.0, 0.5])
    T, why = estimate_transform(pts, transform_points(pose_4dof(1, 2, 0, 0.7), pts), dof=4)
    assert why is None and max(pose_error(T, pose_4dof(1, 2, 0, 0.7))) < 1e-9


def test_mismatched_sizes_and_bad_weights() -> None:
    assert estimate_transform(np.zeros((3, 3)), np.zeros((4, 3)))[1].startswith("src and dst")
    pts = np.eye(3)
    assert "weights" in estimate_transform(pts, pts, np.array([1.0, -1.0, 1.0]))[1]


def test_tilt_ok() -> None:
    assert tilt_ok(make_T(rpy_to_R(0.0, np.deg2rad(4.0), 3.0)), 5.0)
    assert not tilt_ok(make_T(rpy_to_R(np.deg2rad(6.0), 0.0, 0.0)), 5.0)
    assert not tilt_ok(make_T(rpy_to_R(np.deg2rad(120.0), 0.0, 0.0)), 90.0)


def test_kabsch_batch_matches_arun() -> None:
    rng = np.random.default_rng(2)
    src = rng.normal(size=(6, 3, 3))
    dst = np.stack([transform_points(make_T(rpy_to_R(*rng.normal(size=3)), rng.normal(size=3)), s) for s in src])
    dst += rng.normal(0, 0.05, dst.shape)
    np.testing.assert_allclose(kabsch_batch(src, dst), np.stack([arun(s, d) for s, d in zip(src, dst)]), atol=1e-10)
