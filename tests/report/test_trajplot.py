"""Top-down trajectory plot: PNG drawn, closure colours as specified, closure lines from a graph, bad input rejected."""

from __future__ import annotations

import io

import matplotlib.image as mpimg
import numpy as np
import pytest

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import make_T, pose_4dof
from roman_sim.core.trajectory import Trajectory
from roman_sim.mapping.types import Submap, SubmapTruth
from roman_sim.posegraph.types import LoopClosure
from roman_sim.report.trajplot import closure_lines, trajectory_png


def _image(png: bytes) -> np.ndarray:
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    return mpimg.imread(io.BytesIO(png))


def _traj(offset: float) -> Trajectory:
    s = np.linspace(0, 2 * np.pi, 30)
    return Trajectory(s, np.stack([make_T(t=[10 * np.cos(a) + offset, 10 * np.sin(a), 0]) for a in s]))


def _count(img: np.ndarray, rgb: tuple[float, float, float], tol: float = 0.08) -> int:
    return int(np.sum(np.all(np.abs(img[..., :3] - np.asarray(rgb)) < tol, axis=-1)))


TAB_RED = (0.839, 0.153, 0.157)
TAB_GREEN = (0.173, 0.627, 0.173)
TAB_BLUE = (0.122, 0.467, 0.706)


def test_png_with_closure_colours():
    truth = {"a": _traj(0.0), "b": _traj(25.0)}
    est = {"a": _traj(0.5)}
    odom = {"b": _traj(24.0).positions}  # plain xyz accepted
    good = [([10, 0, 0], [15, 0, 0], "inter", True)]
    png = trajectory_png(truth, est, odom, good, title="t")
    assert trajectory_png(truth, est, odom, good, title="t") == png  # same data, same bytes
    img_good = _image(png)
    assert _count(img_good, TAB_RED) == 0  # robot colours avoid red, closure green
    assert _count(img_good, TAB_GREEN) > 20
    assert _count(img_good, TAB_BLUE) == 0  # blue is kept for intra-robot closures
    wrong = good + [([0, -10, 0], [25, 10, 0], "intra", False)]
    img_wrong = _image(trajectory_png(truth, closures=wrong))
    assert _count(img_wrong, TAB_RED) > 20  # the wrong intra closure is red, not blue
    assert _count(img_wrong, TAB_BLUE) == 0


def _submap(robot: str, index: int, x: float, y: float, yaw_deg: float) -> Submap:
    T = pose_4dof(x, y, 0.0, np.radians(yaw_deg))
    empty = np.zeros((0, 3))
    return Submap(
        robot,
        index,
        float(index),
        T,
        np.zeros(0, np.int64),
        empty,
        np.zeros(0),
        empty,
        np.zeros((0, 4)),
        empty,
        truth=SubmapTruth(T, np.zeros(0, np.int64), np.zeros(0)),
    )


def test_closure_lines_keep_the_used_closures_and_judge_them_against_truth():
    subs = {s.name: s for s in (_submap("a", 0, 0, 0, 0), _submap("b", 0, 3, 4, 90), _submap("a", 2, 10, 0, 0))}
    true_ab = np.linalg.inv(subs["a/0"].truth.T_world_submap) @ subs["b/0"].truth.T_world_submap
    off = pose_4dof(0.0, 0.0, 0.0, np.radians(30.0)) @ true_ab  # 30 deg off: wrong at 5 deg tolerance
    closures = [
        LoopClosure("a", 0, "b", 0, true_ab, n_associations=8),  # used, right
        LoopClosure("a", 0, "b", 0, off, n_associations=8),  # used, wrong
        LoopClosure("a", 0, "a", 2, true_ab, n_associations=8),  # not used by the graph (weight None)
        LoopClosure("a", 2, "b", 0, true_ab, n_associations=2),  # below the association threshold
    ]
    lines = closure_lines(closures, [1.0, 0.0, None, 1.0], subs, 4, 5.0, 1.0)
    assert [(kind, ok) for _, _, kind, ok in lines] == [("inter", True), ("inter", False)]
    np.testing.assert_allclose(lines[0][1], [3.0, 4.0, 0.0])  # between the true submap centres


def test_bad_inputs():
    truth = {"a": _traj(0.0)}
    with pytest.raises(EvaluationError, match="kind 'loop' unknown"):
        trajectory_png(truth, closures=[([0, 0, 0], [1, 1, 0], "loop", None)])
    with pytest.raises(EvaluationError, match="no trajectories"):
        trajectory_png({})
    with pytest.raises(EvaluationError, match=r"truth\[a\]"):
        trajectory_png({"a": np.zeros((5, 2))})
