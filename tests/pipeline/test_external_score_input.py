"""``roman-sim score`` on bad input: one line naming the file, the line and what is allowed; nothing written."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import gtsam
import pytest

from roman_sim.pipeline.result import RunResult

GOOD = "a,10.0,b,20.0,1.0,2.0,0.0,0.0,0.0,0.0,1.0,7"
INFO = " ".join(["1"] * 21)


def _g2o(key_a: str, key_b: str, quat: str = "0 0 0 1") -> str:
    return f"# LC: 5\nEDGE_SE3:QUAT {key_a} {key_b} 1 2 0 {quat} {INFO}\n"


A0, B3, C1 = gtsam.symbol("a", 0), gtsam.symbol("b", 3), gtsam.symbol("c", 1)
TIMES = "0 0 10000000000 a\n1 3 20000000000 b\n2 1 5000000000 c\n"

CSV_CASES = {
    "unknown robot": ("a,10.0,z,20.0,1,2,0,0,0,0,1,7", ":2: robot 'z' is not a robot of the run (allowed: a, b)"),
    "time outside": (
        "a,10.0,b,999.0,1,2,0,0,0,0,1,7",
        ":2: time 999.000000 s of robot b is outside the run (allowed: ",
    ),
    "negative time": ("a,-1,b,20,1,2,0,0,0,0,1,7", ":2: t_a: -1.0 s is negative"),
    "non-rigid": (
        "a,10.0,b,20.0,1,2,0,0,0,0.5,0.5,7",
        ":2: quaternion norm 0.707107: a rigid relative pose needs a unit",
    ),
    "short line": ("a,10.0,b,20.0,1,2,0,0,0,1", ":2: 10 fields; a closure line is robot_a,t_a,robot_b,t_b,"),
    "not a number": ("a,10.0,b,20.0,1,two,0,0,0,0,1,7", ":2: relative pose: not a number in"),
    "bad score": ("a,10.0,b,20.0,1,2,0,0,0,0,1,many", ":2: score 'many': must be a whole number"),
}


@pytest.mark.parametrize("case", sorted(CSV_CASES))
def test_bad_csv_line(smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str], case: str) -> None:
    line, message = CSV_CASES[case]
    path = tmp_path / "c.csv"
    path.write_text(f"robot_a,t_a,robot_b,t_b,x,y,z,qx,qy,qz,qw,score\n{line}\n{GOOD}\n", encoding="utf-8")
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "--closures", path, "--out", out)
    assert err.startswith(f"error: {path}{message}"), err
    assert not out.exists()


G2O_CASES = {
    "unknown symbol": (
        _g2o(str(A0), str(C1)),
        ":2: key of Symbol character 'c': no such robot (allowed: 'a' (a), 'b' (b))",
    ),
    "non-rigid": (_g2o(str(A0), str(B3), "0 0 0.6 0.6"), ":2: quaternion norm 0.848528: a rigid relative pose"),
    "short edge": (
        f"EDGE_SE3:QUAT {A0} {B3} 1 2 0 0 0 0 1\n",
        ":1: EDGE_SE3:QUAT needs key1 key2 x y z qx qy qz qw and 21",
    ),
    "text keys": (_g2o("a0", "b3"), ":2: EDGE_SE3:QUAT: keys must be whole numbers (gtsam Symbol keys), got a0 b3"),
    "other tag": ("EDGE_SE2 0 1 1 2 0 1 0 0 1 0 1\n", ":1: unsupported tag 'EDGE_SE2' (allowed: VERTEX_SE3:QUAT"),
    "no time": (_g2o(str(A0), str(gtsam.symbol("b", 9))), ":2: keyframe 9 of robot b (id 1) has no time"),
}


@pytest.mark.parametrize("case", sorted(G2O_CASES))
def test_bad_g2o_line(smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str], case: str) -> None:
    text, message = G2O_CASES[case]
    path, times = tmp_path / "c.g2o", tmp_path / "c.time.txt"
    path.write_text(text, encoding="utf-8")
    times.write_text(TIMES, encoding="utf-8")
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "--closures", path, "--times", times, "--out", out)
    assert err.startswith(f"error: {path}{message}"), err
    assert not out.exists()


def test_g2o_needs_its_times(smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str]) -> None:
    path = tmp_path / "c.g2o"
    path.write_text(_g2o(str(A0), str(B3)), encoding="utf-8")
    err = cli_fails("score", smoke_run.run_dir, "--closures", path, "--out", tmp_path / "out")
    assert err == f"error: --closures {path}: a g2o file needs its timestamps file (--times)"


def test_trajectories_that_do_not_cover_the_run(
    smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    closures = tmp_path / "c.csv"
    closures.write_text(GOOD + "\n", encoding="utf-8")
    traj = tmp_path / "traj"
    traj.mkdir()
    for r in ("a", "b"):
        rows = (smoke_run.run_dir / "trajectories" / f"{r}.roman.tum").read_text(encoding="utf-8").splitlines()
        (traj / f"{r}.tum").write_text("\n".join(rows[: len(rows) // 2] if r == "b" else rows) + "\n", encoding="utf-8")
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--trajectories", traj, "--out", out)
    assert err.startswith(f"error: {traj / 'b.tum'}: covers 0.000 to "), err
    assert "robot b runs 0.000 to " in err and "(allowed: from at most 1 s after its first frame" in err
    assert not out.exists()
    (traj / "b.tum").unlink()
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--trajectories", traj, "--out", out)
    assert err.startswith(f"error: --trajectories {traj}: no b.tum or b.csv (one file per robot: a.tum, b.tum, or ")
    (traj / "b.csv").write_text("time,x,y,z\n", encoding="utf-8")
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--trajectories", traj, "--out", out)
    assert err == f"error: {traj / 'b.csv'}:1: a trajectory CSV starts with the header #timestamp_kf,x,y,z,qw,qx,qy,qz"


def test_source_and_out_checked(smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str]) -> None:
    closures = tmp_path / "c.csv"
    closures.write_text(GOOD + "\n", encoding="utf-8")
    err = cli_fails("score", tmp_path, "--closures", closures, "--out", tmp_path / "out")
    assert err == f"error: {tmp_path}: neither a run folder (manifest.json) nor an export folder (export.json)"
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--out", smoke_run.run_dir)
    assert err == f"error: --out {smoke_run.run_dir}: already holds files (choose a new folder)"
    err = cli_fails("score", smoke_run.run_dir, "--closures", tmp_path / "c.txt", "--out", tmp_path / "o")
    assert err == f"error: --closures {tmp_path / 'c.txt'}: no such file"
