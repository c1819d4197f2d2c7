"""``roman-sim score`` on arrays: the closures' poses, checks and unscored lines without an object per closure.

Each part is checked against the per-closure arithmetic it replaces: scipy's ``Slerp`` at one
time, ``write_record``'s bytes, the first failing line of a loop.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from roman_sim.core.errors import ConfigError
from roman_sim.core.records import write_record
from roman_sim.core.trajectory import Trajectory
from roman_sim.interop.closures import Closure, ClosureSet
from roman_sim.scoring.closure_pairs import Unscored, pose_at, poses_at
from roman_sim.scoring.external import ExternalRecord, _check_closures, _write_external


def _one_slerp(traj: Trajectory, t: float) -> np.ndarray:
    """The pose at ``t`` closure by closure: a frame's own within 1 us, else linear and ``Slerp``."""
    i = int(np.argmin(np.abs(traj.t - t)))
    if abs(traj.t[i] - t) <= 1e-6:
        return traj.T[i]
    j = int(np.clip(np.searchsorted(traj.t, t), 1, len(traj) - 1))
    t0, t1 = traj.t[j - 1], traj.t[j]
    w = float(np.clip((t - t0) / (t1 - t0), 0.0, 1.0))
    T = np.eye(4)
    T[:3, :3] = Slerp([t0, t1], Rotation.from_matrix(traj.T[j - 1 : j + 1, :3, :3]))([t0 + w * (t1 - t0)]).as_matrix()[
        0
    ]
    T[:3, 3] = (1 - w) * traj.T[j - 1, :3, 3] + w * traj.T[j, :3, 3]
    return T


def test_poses_between_frames_are_scipys_slerp_to_the_bit() -> None:
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.05, 0.3, 40))
    t[10] = t[9]  # a repeated stamp: the first of the two frames is the nearest
    T = np.tile(np.eye(4), (40, 1, 1))
    T[:, :3, :3] = Rotation.from_rotvec(rng.normal(size=(40, 3))).as_matrix()
    T[:, :3, 3] = rng.normal(size=(40, 3)) * 10
    traj = Trajectory(t, T)
    times = np.concatenate([rng.uniform(t[0] - 0.5, t[-1] + 0.5, 500), t, t + 4e-7, t - 3e-6])
    got = poses_at(traj, times)
    for k, x in enumerate(times):
        assert np.array_equal(got[k], _one_slerp(traj, float(x))), x
    assert np.array_equal(pose_at(traj, float(times[3])), got[3])
    assert np.array_equal(poses_at(traj, np.asarray([t[10]])), traj.T[9:10])


def test_the_unscored_lines_map_line_to_reason() -> None:
    u = Unscored(np.asarray([9, 2, 5]), np.asarray([1, 0, 1]), ["first", "second"])
    assert list(u) == [2, 5, 9] and len(u) == 3 and u[9] == "second" and u == {2: "first", 5: "second", 9: "second"}
    with pytest.raises(KeyError):
        u[3]
    assert Unscored.of({4: "x", 1: "y"}) == {1: "y", 4: "x"}


@pytest.mark.parametrize("n", [0, 3, 40_000])  # none, one chunk, several
def test_external_json_streamed_is_write_records_bytes(tmp_path: Path, n: int) -> None:
    rng = np.random.default_rng(n)
    lines = rng.choice(10 * n + 1, n, replace=False) + 1
    reasons = {int(line): f'pair a/{line % 7}|b/1 "{line % 3}" é' for line in lines}
    info = ExternalRecord("roman_sim.external_score", 1, "ext", "src", "c.csv", None, ["a", "b"], None, n, 1, {})
    write_record(tmp_path / "ref.json", replace(info, unscored={str(k): v for k, v in reasons.items()}))
    _write_external(tmp_path / "got.json", info, Unscored.of(reasons))
    assert (tmp_path / "got.json").read_bytes() == (tmp_path / "ref.json").read_bytes()


def test_the_first_failing_closure_end_is_named(tmp_path: Path) -> None:
    """In file order, a's end before b's, the robot before its time: what a loop over the closures reports."""
    T = np.eye(4)
    rows = [
        Closure("a", 1.0, "b", 2.0, T, line=2),
        Closure("a", 1.0, "b", 99.0, T, line=3),  # b's time outside
        Closure("z", 1.0, "b", 2.0, T, line=4),
    ]
    times = {"a": np.asarray([0.0, 1.0, 10.0]), "b": np.asarray([0.5, 2.0, 20.0])}
    _check_closures(tmp_path / "c.csv", ClosureSet.of(rows[:1]), times)
    with pytest.raises(ConfigError, match=r"c.csv:3: time 99.000000 s of robot b matches no frame within 0.01 s"):
        _check_closures(tmp_path / "c.csv", ClosureSet.of(rows), times)
    with pytest.raises(ConfigError, match=r"c.csv:4: robot 'z' is not a robot of the run \(allowed: a, b\)"):
        _check_closures(tmp_path / "c.csv", ClosureSet.of([rows[0], rows[2], rows[1]]), times)
