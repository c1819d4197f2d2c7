"""Geometry helpers against hand-computed values."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from roman_sim.core import geometry as g


def test_inverse_and_compose():
    T = g.make_T(g.rpy_to_R(0.1, -0.2, 1.3), [1.0, -2.0, 0.5])
    assert np.allclose(g.inv_T(T) @ T, np.eye(4))


def test_rpy_round_trip():
    r, p, y = 0.2, -0.4, 2.5
    assert np.allclose(g.R_to_rpy(g.rpy_to_R(r, p, y)), (r, p, y))


def test_gravity_aligned_keeps_yaw_and_translation():
    T = g.make_T(g.rpy_to_R(0.3, 0.2, 1.0), [4, 5, 6])
    G = g.gravity_aligned(T)
    assert np.isclose(g.yaw_of(G), 1.0)
    assert np.allclose(G[:3, 3], [4, 5, 6])
    assert np.allclose(G[2, :3], [0, 0, 1])


def test_flu_rdf_axes():
    # camera z (forward) is body x; camera x (right) is body -y; camera y (down) is body -z
    assert np.allclose(g.R_FLU_RDF @ [0, 0, 1], [1, 0, 0])
    assert np.allclose(g.R_FLU_RDF @ [1, 0, 0], [0, -1, 0])
    assert np.allclose(g.R_FLU_RDF @ [0, 1, 0], [0, 0, -1])
    assert np.isclose(np.linalg.det(g.R_FLU_RDF), 1.0)


@pytest.mark.parametrize("seed", range(5))
def test_arun_recovers_transform(seed):
    rng = np.random.default_rng(seed)
    P = rng.uniform(-10, 10, size=(12, 3))
    T = g.make_T(g.rpy_to_R(*rng.uniform(-1, 1, 3)), rng.uniform(-5, 5, 3))
    assert np.allclose(g.arun(P, g.transform_points(T, P)), T, atol=1e-9)


def test_arun_4dof_recovers_yaw_translation():
    rng = np.random.default_rng(3)
    P = rng.uniform(-10, 10, size=(8, 3))
    T = g.pose_4dof(1.0, -3.0, 0.4, -2.9)
    assert np.allclose(g.arun_4dof(P, g.transform_points(T, P)), T, atol=1e-9)


def test_arun_never_returns_reflection():
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    Q = P * np.array([1, 1, -1.0])  # mirrored
    assert np.isclose(np.linalg.det(g.arun(P, Q)[:3, :3]), 1.0)


def test_pose_error():
    T = g.pose_4dof(0, 0, 0, 0)
    E = g.pose_4dof(3, 4, 0, np.radians(10))
    rot, trans = g.pose_error(E, T)
    assert np.isclose(np.degrees(rot), 10)
    assert np.isclose(trans, 5)


def test_pca_features_line_plane_blob():
    rng = np.random.default_rng(0)
    line = np.c_[rng.uniform(0, 5, 500), rng.normal(0, 0.01, 500), rng.normal(0, 0.01, 500)]
    plane = np.c_[rng.uniform(0, 5, 500), rng.uniform(0, 5, 500), rng.normal(0, 0.01, 500)]
    blob = rng.normal(0, 1, (2000, 3))
    lin, pla, sca = g.pca_shape_features(line)
    assert lin > 0.98 and pla < 0.02 and sca < 0.01
    lin, pla, sca = g.pca_shape_features(plane)
    assert lin < 0.15 and pla > 0.85
    lin, pla, sca = g.pca_shape_features(blob)
    assert sca > 0.8
    # features sum: lin + pla + sca = (e1 - e2 + e2 - e3 + e3) / e1 = 1
    assert np.isclose(lin + pla + sca, 1.0)
    assert g.pca_shape_features(np.zeros((2, 3))) == (0.0, 0.0, 0.0)


def test_voxel_downsample_means_per_voxel():
    pts = np.array([[0.01, 0.01, 0.01], [0.03, 0.03, 0.03], [1.0, 1.0, 1.0]])
    out = g.voxel_downsample(pts, 0.05)
    assert len(out) == 2
    assert np.allclose(out[0], [0.02, 0.02, 0.02])
    assert len(g.voxel_keys(pts, 0.05)) == 2


def test_wrap_angle():
    assert np.isclose(g.wrap_angle(3 * np.pi), np.pi)
    assert np.isclose(g.wrap_angle(-np.pi / 2), -np.pi / 2)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 3e-9, 1e-6, 0.3, 1.0, np.pi / 2, 3.0, np.pi - 1e-9, np.pi])
def test_rotation_angle_is_accurate_over_the_whole_range(angle):
    """Relative accuracy near 0 (arccos of the trace has a floor near 1.5e-8 rad) and near pi."""
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    R = Rotation.from_rotvec(angle * axis).as_matrix()
    assert g.rotation_angle(R) == pytest.approx(angle, rel=1e-6, abs=1e-15)
    assert g.pose_error(g.make_T(R, [1, 2, 3]), g.make_T(t=[1, 2, 3]))[0] == pytest.approx(angle, rel=1e-6, abs=1e-15)
