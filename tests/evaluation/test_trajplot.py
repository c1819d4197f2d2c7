"""Top-down trajectory plot: file written, closure colours drawn as specified, bad input rejected."""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np
import pytest

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import make_T
from roman_sim.core.trajectory import Trajectory
from roman_sim.report.trajplot import plot_trajectories


def _traj(offset: float) -> Trajectory:
    s = np.linspace(0, 2 * np.pi, 30)
    return Trajectory(s, np.stack([make_T(t=[10 * np.cos(a) + offset, 10 * np.sin(a), 0]) for a in s]))


def _count(img: np.ndarray, rgb: tuple[float, float, float], tol: float = 0.08) -> int:
    return int(np.sum(np.all(np.abs(img[..., :3] - np.asarray(rgb)) < tol, axis=-1)))


TAB_RED = (0.839, 0.153, 0.157)
TAB_GREEN = (0.173, 0.627, 0.173)
TAB_BLUE = (0.122, 0.467, 0.706)


def test_writes_png_with_closure_colours(tmp_path):
    truth = {"a": _traj(0.0), "b": _traj(25.0)}
    est = {"a": _traj(0.5)}
    odom = {"b": _traj(24.0).positions}  # plain xyz accepted
    good = [([10, 0, 0], [15, 0, 0], "inter", True)]
    out = plot_trajectories(tmp_path / "plots" / "traj.png", truth, est, odom, good, title="t")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img_good = mpimg.imread(out)
    assert _count(img_good, TAB_RED) == 0  # robot colours avoid red, closure green
    assert _count(img_good, TAB_GREEN) > 20
    assert _count(img_good, TAB_BLUE) == 0  # blue is kept for intra-robot closures
    wrong = good + [([0, -10, 0], [25, 10, 0], "intra", False)]
    img_wrong = mpimg.imread(plot_trajectories(tmp_path / "w.png", truth, closures=wrong))
    assert _count(img_wrong, TAB_RED) > 20  # the wrong intra closure is red, not blue
    assert _count(img_wrong, TAB_BLUE) == 0
    assert not list(tmp_path.glob("**/.*.tmp"))  # atomic write left no temp file


def test_bad_inputs(tmp_path):
    truth = {"a": _traj(0.0)}
    with pytest.raises(EvaluationError, match="kind 'loop' unknown"):
        plot_trajectories(tmp_path / "x.png", truth, closures=[([0, 0, 0], [1, 1, 0], "loop", None)])
    with pytest.raises(EvaluationError, match="no trajectories"):
        plot_trajectories(tmp_path / "x.png", {})
    with pytest.raises(EvaluationError, match=r"truth\[a\]"):
        plot_trajectories(tmp_path / "x.png", {"a": np.zeros((5, 2))})
    assert not (tmp_path / "x.png").exists()
