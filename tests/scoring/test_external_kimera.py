"""Kimera-Multi's ``loop_closures.csv``, written from a run's closures as Kimera-Multi logs them, scored.

The writer here follows Kimera-Distributed's ``createLogFiles``, ``logLoopClosure`` and
``logOdometryPose`` (one log folder per robot, ``kimera<i>/``; every exported frame a
keyframe, stamped on the export's clock), independent of the reader. Kimera-Multi's
closures carry no association count: each counts as accepted, so the run's accepted closures
give the run's acceptance point.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from roman_sim.interop.base import EXPORT_EPOCH_NS
from roman_sim.interop.closures import Closure
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.stages.maps import MapsStage
from roman_sim.scoring.external import _load_stage, read_external, run_closures, score_external

ROBOTS = ("a", "b")


def _fmt(v: float) -> str:
    return f"{float(v):.15f}"  # Kimera-Distributed's std::fixed, std::setprecision(15)


def _write_kimera(root: Path, closures: list[Closure], odometry: dict) -> None:
    """Each robot's log folder: its keyframes (every frame) and the closures it detected (robot1 = it)."""
    for i, r in enumerate(ROBOTS):
        folder = root / f"kimera{i}"
        folder.mkdir(parents=True)
        od = odometry[r]
        rows = ["stamp_ns,robot_index,pose_index,qx,qy,qz,qw,tx,ty,tz"]
        for k, (t, T) in enumerate(zip(od.t, od.T)):
            q = Rotation.from_matrix(T[:3, :3]).as_quat()
            rows.append(",".join([str(EXPORT_EPOCH_NS + round(t * 1e9)), str(i), str(k), *map(_fmt, [*q, *T[:3, 3]])]))
        (folder / "odometry_poses.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
        lc = ["robot1,pose1,robot2,pose2,qx,qy,qz,qw,tx,ty,tz,norm_bow_score,mono_inliers,stereo_inliers,stamp_ns"]
        for c in closures:
            if c.robot_a != r:
                continue
            k1 = int(np.argmin(np.abs(odometry[c.robot_a].t - c.t_a)))
            k2 = int(np.argmin(np.abs(odometry[c.robot_b].t - c.t_b)))
            q = Rotation.from_matrix(c.T_pa_pb[:3, :3]).as_quat()
            ids = [str(i), str(k1), str(ROBOTS.index(c.robot_b)), str(k2)]
            lc.append(",".join([*ids, *map(_fmt, [*q, *c.T_pa_pb[:3, 3]]), "0.25", "40", "25", "1765432100000000000"]))
        (folder / "loop_closures.csv").write_text("\n".join(lc) + "\n", encoding="utf-8")


@pytest.fixture(scope="module")
def logs(smoke_run: RunResult, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Closure]]:
    """Kimera-Multi's logs of the run's accepted ROMAN closures."""
    k = smoke_run.metrics.acceptance_k
    assert k is not None
    accepted = [c for c in run_closures(smoke_run.run_dir, "roman") if (c.score or 0) >= k]
    maps = _load_stage(smoke_run.run_dir, smoke_run.scenario, MapsStage()).maps
    root = tmp_path_factory.mktemp("kimera") / "logs"
    _write_kimera(root, accepted, {r: maps[r].odometry for r in ROBOTS})
    return root, accepted


def test_kimera_multi_logs_give_the_acceptance_point(
    smoke_run: RunResult, logs: tuple[Path, list[Closure]], tmp_path: Path
) -> None:
    root, accepted = logs
    res = score_external(smoke_run.run_dir, root, tmp_path / "out", label="kimera_multi")
    assert res.n_closures == res.n_pairs == len(accepted) and res.unscored == {} and res.warning is None
    got, was = res.run.metrics.methods["kimera_multi"], smoke_run.metrics.methods["roman"]
    for kind in ("inter", "intra"):
        assert (
            got.set(kind).overall.operating_points["acceptance"] == was.set(kind).overall.operating_points["acceptance"]
        )
    got_ate, was_ate = res.run.ate.variants["kimera_multi"].rmse, smoke_run.ate.variants["roman"].rmse
    for fit, cells in was_ate.items():  # its 15 decimals carry the poses to about 1e-15
        for cell, v in cells.items():
            assert got_ate[fit][cell] == pytest.approx(v, abs=1e-9)
    info = read_external(tmp_path / "out")
    assert info.closure_format == "kimera_multi"
    epoch = f"the export's clock (epoch {EXPORT_EPOCH_NS} ns taken off)"
    assert info.clocks == {"kimera0/loop_closures.csv": epoch, "kimera1/loop_closures.csv": epoch}


def test_one_robots_file_with_every_robots_keyframes(
    smoke_run: RunResult, logs: tuple[Path, list[Closure]], tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    root, accepted = logs
    mine = root / "kimera0" / "loop_closures.csv"
    n_lines = len(mine.read_text(encoding="utf-8").splitlines())
    res = score_external(smoke_run.run_dir, mine, tmp_path / "out", times=root)
    assert res.n_closures == n_lines - 1 == sum(1 for c in accepted if c.robot_a == "a")
    # alone, its folder holds robot a's keyframes only: the first closure with robot b is one line
    first_b = next(n for n, c in enumerate(c for c in accepted if c.robot_a == "a") if c.robot_b == "b") + 2
    k = mine.read_text(encoding="utf-8").splitlines()[first_b - 1].split(",")[3]
    err = cli_fails("score", smoke_run.run_dir, "-c", mine, "-o", tmp_path / "o2")
    assert err == (
        f"error: {mine}:{first_b}: keyframe {k} of robot b (index 1) has no time in the odometry_poses.csv files under "
        f"{root / 'kimera0'} (each robot writes its own: give a folder holding every robot's with --times)"
    )
    assert not (tmp_path / "o2").exists()


def test_an_odometry_file_for_an_unknown_robot(
    smoke_run: RunResult, logs: tuple[Path, list[Closure]], tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    root, _ = logs
    third = tmp_path / "logs" / "kimera2"
    third.mkdir(parents=True)
    for f in ("odometry_poses.csv", "loop_closures.csv"):
        (tmp_path / "logs" / "kimera0").mkdir(exist_ok=True)
        (tmp_path / "logs" / "kimera0" / f).write_bytes((root / "kimera0" / f).read_bytes())
    (third / "odometry_poses.csv").write_text(
        "stamp_ns,robot_index,pose_index,qx,qy,qz,qw,tx,ty,tz\n1700000000000000000,2,0,0,0,0,1,0,0,0\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "-c", tmp_path / "logs", "-o", out)
    assert (
        err == f"error: {third / 'odometry_poses.csv'}:2: robot_index 2 is no robot of the run (allowed: 0 (a), 1 (b))"
    )
    assert not out.exists()
