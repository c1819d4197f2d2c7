"""The ATE table: every row over the same robots, placed counts, joint and per-robot fits, by hand."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from roman_sim.core.errors import EvaluationError, StorageError
from roman_sim.core.trajectory import Trajectory
from roman_sim.evaluation.atetable import AteTable, TrajectoryVariant, ate_table, read_ate, write_ate

V = np.array([0.0, 0.0, 0.8])  # offset of |v| = 0.8 m


def _traj(xyz: np.ndarray, t0: float = 0.0) -> Trajectory:
    T = np.tile(np.eye(4), (len(xyz), 1, 1))
    T[:, :3, 3] = xyz
    return Trajectory(t0 + np.arange(len(xyz), dtype=float), T)


P = np.array([[0, 0, 0], [3, 0, 0], [3, 2, 0], [0, 2, 1], [1, 1, 2], [2, 1, 0.5]], dtype=float)
LINE = np.stack([np.arange(5.0), np.zeros(5), np.zeros(5)], 1) + [10.0, 0, 0]
TRUTH = {"r1": _traj(LINE), "r2": _traj(P), "r3": _traj(P)}


def _kabsch_rmse(est: np.ndarray, ref: np.ndarray) -> float:
    """Independent rigid fit (Umeyama without scale) and the RMSE after it."""
    ce, cr = est.mean(0), ref.mean(0)
    U, _, Vt = np.linalg.svd((ref - cr).T @ (est - ce))
    D = np.diag([1, 1, np.sign(np.linalg.det(U @ Vt))])
    R = U @ D @ Vt
    return float(np.sqrt(np.mean(np.sum((ref - ((est - ce) @ R.T + cr)) ** 2, axis=1))))


@pytest.fixture
def table() -> AteTable:
    odom = {"r1": _traj(LINE), "r2": _traj(P + V), "r3": _traj(P - V)}
    graph = {"r1": _traj(LINE), "r2": _traj(P)}  # r3 never connected
    return ate_table(
        TRUTH,
        {
            "odometry": TrajectoryVariant("odometry", "joint", "odometry"),
            "odometry_no_prior": TrajectoryVariant("odometry aligned robot by robot", "per_robot", "odometry"),
            "graph": TrajectoryVariant("pose graph", "joint", "graph"),
        },
        {"odometry": odom, "graph": graph},
        ("se3",),
    )


def test_every_row_covers_the_robots_every_row_placed(table):
    assert table.robots == ["r1", "r2", "r3"] and table.common == ["r1", "r2"]
    assert {k: v.connected for k, v in table.variants.items()} == {
        "odometry": ["r1", "r2", "r3"],
        "odometry_no_prior": ["r1", "r2", "r3"],
        "graph": ["r1", "r2"],
    }
    # over the common robots r1, r2: odometry's r2 is 0.8 m up, one fit for both
    assert table.rmse("odometry") == pytest.approx(_kabsch_rmse(np.vstack([LINE, P + V]), np.vstack([LINE, P])))
    assert table.rmse("graph") == pytest.approx(0.0, abs=1e-9)
    # all robots: r2 and r3 offset by +v and -v are symmetric, so the joint fit is the identity: error |v| on 12 of 17
    assert table.rmse("odometry", robot="all") == pytest.approx(math.sqrt(12 * 0.8**2 / 17))
    assert table.rmse("graph", robot="all") is None  # did not place every robot: not connected
    assert table.rmse("graph", robot="r3") is None


def test_per_robot_fit_removes_each_offset(table):
    for robot in ("common", "all", "r1", "r2", "r3"):
        assert table.rmse("odometry_no_prior", robot=robot) == pytest.approx(0.0, abs=1e-9)
    # per-robot cells align each robot on its own, whatever the variant's fit
    assert table.rmse("odometry", robot="r2") == pytest.approx(0.0, abs=1e-9)


def test_json_round_trip_keeps_the_row_order(table, tmp_path):
    write_ate(tmp_path / "ate.json", table, [])
    back, notes = read_ate(tmp_path / "ate.json")
    assert list(back.variants) == ["odometry", "odometry_no_prior", "graph"] and notes == []
    assert back == table
    (tmp_path / "old.json").write_text(json.dumps({"schema": "roman_sim.ate/1", "variants": {}}))
    with pytest.raises(StorageError, match="schema"):
        read_ate(tmp_path / "old.json")


def test_bad_tables_are_clear_errors(table):
    with pytest.raises(EvaluationError, match="unknown"):
        table.rmse("combined")
    with pytest.raises(EvaluationError, match="robot"):
        table.rmse("graph", robot="r9")
    with pytest.raises(EvaluationError, match="no true trajectory"):
        ate_table(TRUTH, {"x": TrajectoryVariant("x")}, {"x": {"r9": _traj(P)}})
    with pytest.raises(EvaluationError, match="ATE variant 'x': no trajectories 'y'"):
        ate_table(TRUTH, {"x": TrajectoryVariant("x", source="y")}, {})
    with pytest.raises(EvaluationError, match="may not be named"):
        ate_table({"all": _traj(P)}, {}, {})
