"""ATE: alignment invariances, hand-computed statistics, association, evo cross-check."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import make_T, pose_4dof, rpy_to_R
from roman_sim.core.trajectory import Trajectory, associate
from roman_sim.core.tum import read_tum, write_tum
from roman_sim.evaluation.ate import align_4dof, align_se3, ate_rmse, multi_robot_ate


def _tr(t: np.ndarray, T: np.ndarray) -> Trajectory:
    return Trajectory(t, T)


def _trajectory(n: int = 40, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A 3D curve with varying attitude (not collinear, not planar)."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 6.0, n)
    xyz = np.column_stack([10 * np.cos(s), 6 * np.sin(1.3 * s), np.sin(2 * s)])
    T = np.stack([make_T(rpy_to_R(*rng.normal(0, 0.05, 2), a), p) for a, p in zip(s, xyz)])
    return s * 2.0, T


def _moved(T_move: np.ndarray, T: np.ndarray) -> np.ndarray:
    return np.einsum("ij,njk->nik", T_move, T)


def test_identical_trajectories_have_zero_error():
    t, T = _trajectory()
    for alignment in ("se3", "4dof", "none"):
        res = ate_rmse(_tr(t, T), _tr(t, T), alignment)
        assert res.rmse_m == pytest.approx(0.0, abs=1e-9)
        assert res.n == len(t)


def test_rigid_copy_is_zero_after_se3_alignment_only():
    t, T = _trajectory()
    T_move = make_T(Rotation.random(random_state=3).as_matrix(), [5.0, -3.0, 2.0])
    moved = _moved(T_move, T)
    res = ate_rmse(_tr(t, moved), _tr(t, T), "se3")
    assert res.rmse_m == pytest.approx(0.0, abs=1e-8)
    np.testing.assert_allclose(res.T_align @ T_move, np.eye(4), atol=1e-8)
    assert ate_rmse(_tr(t, moved), _tr(t, T), "none").rmse_m > 1.0
    assert ate_rmse(_tr(t, moved), _tr(t, T), "4dof").rmse_m > 0.1  # roll/pitch cannot be undone in 4 DoF


def test_yaw_translation_copy_is_zero_after_4dof_alignment():
    t, T = _trajectory()
    moved = _moved(pose_4dof(3.0, 4.0, -1.0, 2.0), T)
    assert ate_rmse(_tr(t, moved), _tr(t, T), "4dof").rmse_m == pytest.approx(0.0, abs=1e-8)
    assert ate_rmse(_tr(t, moved), _tr(t, T), "se3").rmse_m == pytest.approx(0.0, abs=1e-8)
    assert ate_rmse(_tr(t, moved), _tr(t, T), "none").rmse_m > 1.0


def test_hand_computed_statistics():
    t = np.array([0.0, 1.0, 2.0])
    ref = np.stack([make_T(t=[x, 0, 0]) for x in (0.0, 1.0, 2.0)])
    est = ref.copy()
    est[:, :3, 3] += [[0, 1, 0], [0, 0, 2], [0, -2, 0]]  # errors 1, 2, 2
    res = ate_rmse(_tr(t, est), _tr(t, ref), "none")
    assert res.rmse_m == pytest.approx(np.sqrt(3.0))
    assert res.mean_m == pytest.approx(5.0 / 3.0)
    assert (res.median_m, res.max_m, res.n) == (pytest.approx(2.0), pytest.approx(2.0), 3)


def test_align_functions_map_estimate_onto_reference():
    _, T = _trajectory()
    T_move = pose_4dof(1.0, 2.0, 3.0, -0.7)
    est, ref = _moved(T_move, T)[:, :3, 3], T[:, :3, 3]
    for fn in (align_se3, align_4dof):
        np.testing.assert_allclose(fn(est, ref), np.linalg.inv(T_move), atol=1e-9)
    with pytest.raises(EvaluationError, match="at least 3"):
        align_se3(est[:2], ref[:2])
    with pytest.raises(EvaluationError, match=r"\(N, 3\)"):
        align_4dof(est[:, :2], ref[:, :2])


def test_association_by_timestamp():
    t, T = _trajectory()
    i_e, i_r = associate(t + 0.004, t, max_diff_s=0.01)
    np.testing.assert_array_equal(i_e, i_r)
    assert ate_rmse(_tr(t + 0.004, T), _tr(t, T), "none").n == len(t)
    assert len(associate(t[::2], t)[0]) == len(t[::2])
    with pytest.raises(EvaluationError, match="only 0 poses matched"):
        ate_rmse(_tr(t + 1000.0, T), _tr(t, T))
    with pytest.raises(EvaluationError, match="at least 3"):
        ate_rmse(_tr(t[:2], T[:2]), _tr(t, T))
    with pytest.raises(EvaluationError, match="alignment 'sim3' unknown"):
        ate_rmse(_tr(t, T), _tr(t, T), "sim3")  # type: ignore[arg-type]
    with pytest.raises(EvaluationError, match="NaN"):
        _tr(t, np.full_like(T, np.nan))
    with pytest.raises(EvaluationError, match="backwards"):
        _tr(t[::-1], T)
    with pytest.raises(EvaluationError, match="shape"):
        _tr(t, T[:3])


def test_multi_robot_uses_one_alignment_for_all():
    t, T = _trajectory()
    ref = {"a": _tr(t, T), "b": _tr(t, _moved(pose_4dof(30, 0, 0, 0), T))}
    est = {"a": ref["a"].transformed(pose_4dof(1, 1, 0, 0.5)), "b": ref["b"].transformed(pose_4dof(-4, 2, 0, -1.0))}
    res = multi_robot_ate(est, ref, "se3")
    assert res["a"].rmse_m == pytest.approx(0.0, abs=1e-8)
    assert res["b"].rmse_m == pytest.approx(0.0, abs=1e-8)
    assert res["all"].rmse_m > 1.0 and res["all"].n == 2 * len(t)
    partial = multi_robot_ate({"a": est["a"]}, ref, "4dof")
    assert partial["b"] is None and partial["all"].n == len(t)
    assert multi_robot_ate({}, ref)["all"] is None
    with pytest.raises(EvaluationError, match="no reference"):
        multi_robot_ate({"c": est["a"]}, ref)
    with pytest.raises(EvaluationError, match="may not be named"):
        multi_robot_ate({}, {"all": ref["a"]})


def test_tum_round_trip_and_evo_agrees(tmp_path):
    t, T = _trajectory()
    est = _moved(make_T(Rotation.from_euler("zyx", [0.4, 0.1, -0.05]).as_matrix(), [2, 1, 0]), T)
    est[:, :3, 3] += np.random.default_rng(1).normal(0, 0.2, (len(t), 3))
    write_tum(tmp_path / "ref.tum", _tr(t, T))
    write_tum(tmp_path / "est.tum", _tr(t, est))
    back = read_tum(tmp_path / "est.tum")
    np.testing.assert_allclose(back.t, t, atol=1e-9)
    np.testing.assert_allclose(back.T, est, atol=1e-8)
    ours = ate_rmse(back, read_tum(tmp_path / "ref.tum"), "se3")

    pytest.importorskip("evo")
    from evo.core import metrics
    from evo.tools import file_interface

    traj_ref = file_interface.read_tum_trajectory_file(str(tmp_path / "ref.tum"))
    traj_est = file_interface.read_tum_trajectory_file(str(tmp_path / "est.tum"))
    np.testing.assert_allclose(traj_est.positions_xyz, est[:, :3, 3], atol=1e-8)
    traj_est.align(traj_ref, correct_scale=False)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((traj_ref, traj_est))
    assert ape.get_statistic(metrics.StatisticsType.rmse) == pytest.approx(ours.rmse_m, rel=1e-6)
