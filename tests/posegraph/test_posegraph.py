"""Multi-robot GNC pose graph against synthetic scenarios with exact truth."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from roman_sim.align.base import AlignResult
from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, EvaluationError
from roman_sim.core.geometry import inv_T, pose_4dof, pose_error
from roman_sim.core.trajectory import Trajectory
from roman_sim.evaluation.ate import multi_robot_ate
from roman_sim.mapping.types import Submap
from roman_sim.posegraph import (
    LoopClosure,
    PoseGraphConfig,
    build_and_solve,
    closure_from_alignment,
    submap_nodes_from,
)
from roman_sim.posegraph.build import build_graph
from roman_sim.posegraph.synthetic import SyntheticGraphConfig, synthetic_scenario

NO_DRIFT = dict(
    drift_yaw_deg=0.0,
    drift_yaw_bias_deg=0.0,
    drift_xyz_m=0.0,
    drift_scale=0.0,
    closure_noise_m=0.0,
    closure_noise_deg=0.0,
)


def _odom_in_world(sc):
    """Odometry-only baseline: each robot placed with its true initial pose."""
    return {r: tr.transformed(sc.T_world_odom[r]) for r, tr in sc.odom.items()}


@pytest.fixture(scope="module")
def drifting():
    return synthetic_scenario(3, SyntheticGraphConfig(n_robots=2, length_m=300, n_closures=20))


def test_recovers_truth_from_drifting_odometry(drifting):
    res = build_and_solve(drifting.odom, drifting.submap_nodes, drifting.closures)
    assert res.unconnected == []
    assert set(res.trajectories) == {"robot0", "robot1"}
    for alignment in ("se3", "4dof"):
        odom = multi_robot_ate(_odom_in_world(drifting), drifting.truth, alignment)["all"]
        opt = multi_robot_ate(res.trajectories, drifting.truth, alignment)["all"]
        assert odom.rmse_m > 1.0  # the scenario really drifts
        assert opt.rmse_m < 0.3 * odom.rmse_m
    assert all(w is not None and w > 0.9 for w in res.closure_weights)


def test_gnc_downweights_false_closures():
    sc = synthetic_scenario(5, SyntheticGraphConfig(n_robots=2, length_m=300, n_closures=30, outlier_fraction=0.3))
    assert sum(not f for f in sc.closure_true) == 9
    res = build_and_solve(sc.odom, sc.submap_nodes, sc.closures)
    w = np.array(res.closure_weights, dtype=float)
    flags = np.array(sc.closure_true)
    assert np.all(w[~flags] < 0.1)
    assert np.all(w[flags] > 0.9)
    assert res.n_inliers == flags.sum()
    odom = multi_robot_ate(_odom_in_world(sc), sc.truth, "se3")["all"]
    opt = multi_robot_ate(res.trajectories, sc.truth, "se3")["all"]
    assert opt.rmse_m < 0.3 * odom.rmse_m


def test_exact_inputs_give_truth_in_first_robot_frame():
    """No drift, exact closures: every robot lands on its truth seen from robot0's odometry frame."""
    sc = synthetic_scenario(1, SyntheticGraphConfig(n_robots=3, length_m=120, n_closures=12, **NO_DRIFT))
    res = build_and_solve(sc.odom, sc.submap_nodes, sc.closures)
    assert res.unconnected == []
    T_o0_w = inv_T(sc.T_world_odom["robot0"])
    for robot, est in res.trajectories.items():
        true = sc.truth[robot]
        np.testing.assert_array_equal(est.t, true.t)
        np.testing.assert_allclose(est.T, T_o0_w @ true.T, atol=1e-4)


def test_unconnected_robot_is_reported():
    sc = synthetic_scenario(2, SyntheticGraphConfig(n_robots=3, length_m=150, n_closures=30))
    kept = [c for c in sc.closures if "robot2" not in (c.robot_a, c.robot_b) or c.robot_a == c.robot_b]
    res = build_and_solve(sc.odom, sc.submap_nodes, kept)
    assert res.unconnected == ["robot2"]
    assert set(res.trajectories) == {"robot0", "robot1"}
    assert res.unconnected_trajectories["robot2"].T.shape == (len(sc.odom["robot2"]), 4, 4)
    ate = multi_robot_ate(res.trajectories, sc.truth, "se3")
    assert ate["robot2"] is None and ate["all"] is not None


def test_no_closures_returns_odometry():
    sc = synthetic_scenario(4, SyntheticGraphConfig(n_robots=2, length_m=60, n_closures=0))
    res = build_and_solve(sc.odom, sc.submap_nodes, [])
    assert res.unconnected == ["robot1"]
    np.testing.assert_allclose(res.trajectories["robot0"].T, sc.odom["robot0"].T, atol=1e-6)
    np.testing.assert_allclose(res.unconnected_trajectories["robot1"].T, sc.odom["robot1"].T, atol=1e-6)


def test_weak_closures_are_not_used(drifting):
    weak = [replace(c, n_associations=3) for c in drifting.closures[:2]]
    res = build_and_solve(
        drifting.odom, drifting.submap_nodes, weak + drifting.closures[2:], PoseGraphConfig(lc_association_thresh=4)
    )
    assert res.closure_weights[:2] == [None, None]
    assert all(w is not None for w in res.closure_weights[2:])


def test_bad_inputs_raise_clear_errors(drifting):
    c = drifting.closures[0]
    with pytest.raises(EvaluationError, match="unknown robot"):
        build_and_solve(drifting.odom, drifting.submap_nodes, [replace(c, robot_a="nobody")])
    with pytest.raises(EvaluationError, match="has no submap 999"):
        build_and_solve(drifting.odom, drifting.submap_nodes, [replace(c, submap_b=999)])
    with pytest.raises(EvaluationError, match="finite 4x4"):
        build_and_solve(drifting.odom, drifting.submap_nodes, [replace(c, T_a_b=np.eye(3))])
    with pytest.raises(EvaluationError, match="sigma_m must be a positive"):
        build_and_solve(drifting.odom, drifting.submap_nodes, [replace(c, sigma_m=-1.0)])
    t, T = drifting.odom["robot0"].t, drifting.odom["robot0"].T
    with pytest.raises(EvaluationError, match="strictly increasing"):
        build_and_solve({"robot0": Trajectory(np.zeros(len(t)), T)}, {}, [])
    with pytest.raises(EvaluationError, match="expected a Trajectory"):
        build_and_solve({"robot0": (t, T)}, {}, [])  # type: ignore[dict-item]
    with pytest.raises(EvaluationError, match="outside the trajectory"):
        build_and_solve({"robot0": Trajectory(t, T)}, {"robot0": [(t[-1] + 100.0, np.eye(4))]}, [])
    with pytest.raises(EvaluationError, match="no trajectories"):
        build_and_solve({}, {}, [])
    with pytest.raises(ConfigError, match="gnc_loss"):
        validate_model(PoseGraphConfig, {"gnc_loss": "huber"})
    with pytest.raises(ConfigError, match="unknown key"):
        validate_model(PoseGraphConfig, {"odom_sigma": 1.0})


def _submap(robot: str, index: int) -> Submap:
    z = np.zeros((0, 3))
    return Submap(
        robot,
        index,
        float(index),
        pose_4dof(index, 0, 0, 0.1 * index),
        np.zeros(0, np.int64),
        z,
        np.zeros(0),
        z,
        np.zeros((0, 4), np.float32),
        z,
    )


def test_submap_helpers():
    subs = [_submap("a", 1), _submap("a", 0), _submap("b", 0)]
    nodes = submap_nodes_from(subs)
    assert [t for t, _ in nodes["a"]] == [0.0, 1.0]
    np.testing.assert_allclose(nodes["a"][1][1], pose_4dof(1, 0, 0, 0.1))
    with pytest.raises(EvaluationError, match="indices must be"):
        submap_nodes_from([_submap("a", 1)])
    ok = AlignResult("roman", pose_4dof(1, 2, 0, 0.3), np.zeros((5, 2), np.int64), np.ones(5), 0.01)
    lc = closure_from_alignment(subs[1], subs[2], ok)
    assert isinstance(lc, LoopClosure)
    got = (lc.robot_a, lc.submap_a, lc.robot_b, lc.submap_b, lc.n_associations, lc.source)
    assert got == ("a", 0, "b", 0, 5, "roman")
    assert lc.inter
    assert closure_from_alignment(subs[1], subs[2], AlignResult.failure("roman", "too few")) is None


def test_synthetic_scenario_is_deterministic():
    cfg = SyntheticGraphConfig(n_robots=2, length_m=60, n_closures=6, outlier_fraction=0.5)
    a, b = synthetic_scenario(9, cfg), synthetic_scenario(9, cfg)
    for robot in a.odom:
        np.testing.assert_array_equal(a.odom[robot].T, b.odom[robot].T)
    assert [c.T_a_b.tobytes() for c in a.closures] == [c.T_a_b.tobytes() for c in b.closures]
    assert a.closure_true == b.closure_true and sum(a.closure_true) == 3
    other = synthetic_scenario(10, cfg)
    assert not np.array_equal(other.odom["robot0"].T, a.odom["robot0"].T)


def test_robust_placement_ignores_one_wrong_closure_that_outranks_consistent_ones():
    """Four consistent closures with 6 associations and one wrong one with 100: consensus places robot1."""
    sc = synthetic_scenario(7, SyntheticGraphConfig(n_robots=2, length_m=300, n_closures=40))
    good = [replace(c, n_associations=6) for c in sc.closures if c.inter][:4]
    T_ws = sc.T_world_submap
    wrong_T = pose_4dof(-8.0, 9.0, 0.0, 2.4) @ inv_T(T_ws["robot0"][3]) @ T_ws["robot1"][20]
    wrong = replace(good[0], submap_a=3, submap_b=20, T_a_b=wrong_T, n_associations=100, source="visual")
    cfg = PoseGraphConfig()
    placed_good = build_graph(sc.odom, sc.submap_nodes, good, cfg).T_root_odom["robot1"]
    parts = build_graph(sc.odom, sc.submap_nodes, good + [wrong], cfg)
    np.testing.assert_allclose(parts.T_root_odom["robot1"], placed_good, atol=1e-6)
    assert parts.placements["robot1"].support == [0, 1, 2, 3]
    # the wrong closure alone puts robot1 far away: the test would fail with the strongest closure
    alone = build_graph(sc.odom, sc.submap_nodes, [wrong], cfg).T_root_odom["robot1"]
    rot_err, _ = pose_error(alone, placed_good)
    assert np.degrees(rot_err) > 60.0
    res = build_and_solve(sc.odom, sc.submap_nodes, good + [wrong], cfg)
    assert res.unconnected == []
    assert res.closure_weights[4] is not None and res.closure_weights[4] < 0.1
    assert all(w is not None and w > 0.9 for w in res.closure_weights[:4])
    clean = build_and_solve(sc.odom, sc.submap_nodes, good, cfg)
    for robot, est in clean.trajectories.items():
        np.testing.assert_allclose(res.trajectories[robot].T, est.T, atol=1e-4)


def test_placement_order_prefers_the_largest_consensus():
    """robot2 reaches robot0 by one closure and robot1 by three: it is placed after robot1, from those three."""
    sc = synthetic_scenario(11, SyntheticGraphConfig(n_robots=3, length_m=200, n_closures=60, **NO_DRIFT))
    inter = [c for c in sc.closures if c.inter]
    pair = {tuple(sorted((c.robot_a, c.robot_b))) for c in inter}
    assert {("robot0", "robot1"), ("robot0", "robot2"), ("robot1", "robot2")} <= pair
    r01 = [c for c in inter if {c.robot_a, c.robot_b} == {"robot0", "robot1"}][:2]
    r02 = [c for c in inter if {c.robot_a, c.robot_b} == {"robot0", "robot2"}][:1]
    r12 = [c for c in inter if {c.robot_a, c.robot_b} == {"robot1", "robot2"}][:3]
    parts = build_graph(sc.odom, sc.submap_nodes, r01 + r02 + r12, PoseGraphConfig())
    assert list(parts.placements) == ["robot1", "robot2"]
    assert sorted(parts.placements["robot2"].candidates) == [2, 3, 4, 5]
    T_o0_w = inv_T(sc.T_world_odom["robot0"])
    for robot in ("robot1", "robot2"):
        np.testing.assert_allclose(parts.T_root_odom[robot], T_o0_w @ sc.T_world_odom[robot], atol=1e-6)
