"""RANSAC on centroid correspondences, and the synthetic submap pairs themselves."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align.ransac import RansacParams, ransac_align
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import pose_4dof, pose_error, transform_points


def test_synthetic_pair_ground_truth() -> None:
    T = pose_4dof(2.0, 1.0, 0.3, 2.0)
    a, b, truth = make_submap_pair(11, 10, 4, 6, T_a_b=T, noise_m=0.0, descriptor_dim=32)
    assert len(a) == 14 and len(b) == 16 and truth.shape == (10, 2)
    np.testing.assert_allclose(transform_points(T, b.centers[truth[:, 1]]), a.centers[truth[:, 0]], atol=1e-9)
    np.testing.assert_array_equal(a.truth.object_ids[truth[:, 0]], b.truth.object_ids[truth[:, 1]])
    assert a.descriptors.shape == (14, 32) and a.descriptors.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(a.descriptors, axis=1), 1.0, atol=1e-5)
    assert (np.diff(a.extents, axis=1) <= 0).all()
    np.testing.assert_allclose(a.volumes, np.prod(a.extents, axis=1))
    r = np.hypot(a.centers[:, 0], a.centers[:, 1])
    assert r.max() <= 15.0 and a.centers[:, 2].min() >= 0 and a.centers[:, 2].max() <= 5.0
    cos = np.sum(a.descriptors[truth[:, 0]] * b.descriptors[truth[:, 1]], axis=1)
    assert cos.min() > 0.95  # same object seen twice


def test_synthetic_pair_is_deterministic_and_seed_dependent() -> None:
    a1, b1, t1 = make_submap_pair(5, 8, 3, 3, descriptor_dim=16)
    a2, b2, t2 = make_submap_pair(5, 8, 3, 3, descriptor_dim=16)
    a3, _, _ = make_submap_pair(6, 8, 3, 3, descriptor_dim=16)
    np.testing.assert_array_equal(a1.centers, a2.centers)
    np.testing.assert_array_equal(b1.descriptors, b2.descriptors)
    np.testing.assert_array_equal(t1, t2)
    assert not np.allclose(a1.centers, a3.centers)


def test_repeated_layout_copies_geometry_with_other_families() -> None:
    a, b, truth = make_submap_pair(2, 6, 0, 0, noise_m=0.0, repeated_layout=True, descriptor_dim=16)
    assert len(a) == 12 and len(b) == 6
    decoys = np.setdiff1d(np.arange(12), truth[:, 0])
    shared = a.centers[truth[:, 0]]
    copy = a.centers[decoys]
    np.testing.assert_allclose(np.sort((shared + [15.0, 0, 0])[:, 0]), np.sort(copy[:, 0]), atol=1e-9)


def test_ransac_recovers_transform_and_inliers() -> None:
    T = pose_4dof(3.0, -2.0, 0.2, 2.8)
    a, b, truth = make_submap_pair(4, 10, 5, 5, T_a_b=T, noise_m=0.03, descriptor_dim=8)
    out = ransac_align(a.centers, b.centers, RansacParams(iterations=200_000, seed=1))
    rot, trans = pose_error(out.T_a_b, T)
    assert np.rad2deg(rot) < 2 and trans < 0.3
    assert set(map(tuple, out.associations)) == set(map(tuple, truth))
    again = ransac_align(a.centers, b.centers, RansacParams(iterations=200_000, seed=1))
    np.testing.assert_array_equal(out.T_a_b, again.T_a_b)


def test_ransac_without_consistent_triples_reports_no_hypothesis() -> None:
    ca = np.array([[0.0, 0, 0], [1, 0, 0], [0, 3, 0]])
    cb = np.array([[0.0, 0, 0], [7, 0, 0], [0, 20, 0]])
    out = ransac_align(ca, cb, RansacParams(iterations=1000))
    assert out.T_a_b is None and "edge check" in out.reason


@pytest.mark.parametrize(
    "kwargs",
    [{"n_inliers": -1}, {"noise_m": -0.1}, {"descriptor_dim": 0}, {"n_families": 1}, {"T_a_b": np.eye(3)}],
)
def test_synthetic_pair_rejects_bad_arguments(kwargs: dict) -> None:
    args = {"seed": 0, "n_inliers": 5, "n_outliers_a": 1, "n_outliers_b": 1} | kwargs
    with pytest.raises(ConfigError):
        make_submap_pair(**args)
