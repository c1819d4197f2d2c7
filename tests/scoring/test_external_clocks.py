"""``roman-sim score`` reads stamps on the export's clock as well as since the start; other stamps fail in one line.

A system run on an exported sequence stamps its output from the export's epoch
(1 700 000 000 s after 1970): the run's own closures and trajectories, restamped so, score
exactly as they do since the start. Trajectories in nanoseconds or 50 ms late match no
frame and fail with one line naming the file, the line and the tolerance.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.records import to_json
from roman_sim.core.tum import read_tum
from roman_sim.interop.base import EXPORT_EPOCH_NS
from roman_sim.interop.closures import Closure, write_csv_closures, write_g2o_closures
from roman_sim.pipeline.result import RunResult
from roman_sim.scoring.external import EXTERNAL_ATE_JSON, read_external, run_closures, score_external

EPOCH_S = EXPORT_EPOCH_NS // 10**9


@pytest.fixture(scope="module")
def closures(smoke_run: RunResult) -> list[Closure]:
    return run_closures(smoke_run.run_dir, "roman")


def _trajectories(smoke_run: RunResult, folder: Path, stamp: Callable[[float], str]) -> Path:
    """The run's ROMAN trajectories as the system's own, each stamp written by ``stamp``."""
    folder.mkdir()
    for r in ("a", "b"):
        rows = (smoke_run.run_dir / "trajectories" / f"{r}.roman.tum").read_text(encoding="utf-8").splitlines()
        text = "".join(" ".join([stamp(float(row.split()[0])), *row.split()[1:]]) + "\n" for row in rows)
        (folder / f"{r}.tum").write_text(text, encoding="utf-8")
    return folder


def _epoch_text(t: float) -> str:
    ns = EXPORT_EPOCH_NS + round(t * 1e9)
    return f"{ns // 10**9}.{ns % 10**9:09d}"


def test_the_export_clock_scores_as_the_start_clock(
    smoke_run: RunResult, closures: list[Closure], tmp_path: Path
) -> None:
    """CSV closures and TUM trajectories stamped on the export's clock, a g2o file whose timestamps file is too."""
    start = _trajectories(smoke_run, tmp_path / "start", lambda t: f"{t:.9f}")
    epoch = _trajectories(smoke_run, tmp_path / "epoch", _epoch_text)
    write_csv_closures(tmp_path / "start.csv", closures)
    rows = (tmp_path / "start.csv").read_text(encoding="utf-8").splitlines()
    cells = [r.split(",") for r in rows[1:]]
    for c in cells:
        c[1], c[3] = _epoch_text(float(c[1])), _epoch_text(float(c[3]))
    (tmp_path / "epoch.csv").write_text("\n".join([rows[0], *map(",".join, cells)]) + "\n", encoding="utf-8")
    a = score_external(smoke_run.run_dir, tmp_path / "start.csv", tmp_path / "a", trajectories=start)
    b = score_external(smoke_run.run_dir, tmp_path / "epoch.csv", tmp_path / "b", trajectories=epoch)
    assert to_json(a.run.metrics) == to_json(b.run.metrics)
    assert a.run.ate.variants["external"].rmse == b.run.ate.variants["external"].rmse
    ate = [json.loads((tmp_path / x / EXTERNAL_ATE_JSON).read_text(encoding="utf-8"))["variants"] for x in "ab"]
    assert ate[0] == ate[1]
    clocks = read_external(tmp_path / "b").clocks
    taken_off = f"the export's clock (epoch {EXPORT_EPOCH_NS} ns taken off)"
    assert clocks == {str(tmp_path / "epoch.csv"): taken_off, "a.tum": taken_off, "b.tum": taken_off}
    assert set(read_external(tmp_path / "a").clocks.values()) == {"seconds since the robot's start"}
    # g2o: its timestamps file in nanoseconds since 1970
    write_g2o_closures(tmp_path / "c.g2o", tmp_path / "c.time.txt", closures, ["a", "b"])
    lines = (tmp_path / "c.time.txt").read_text(encoding="utf-8").splitlines()
    shifted = [" ".join([*p[:2], str(EXPORT_EPOCH_NS + int(p[2])), *p[3:]]) for p in (ln.split() for ln in lines)]
    (tmp_path / "c.time.txt").write_text("\n".join(shifted) + "\n", encoding="utf-8")
    g = score_external(smoke_run.run_dir, tmp_path / "c.g2o", tmp_path / "g", times=tmp_path / "c.time.txt")
    assert to_json(g.run.metrics) == to_json(a.run.metrics)


@pytest.mark.parametrize(
    ("case", "stamp", "message"),
    [
        (
            "nanoseconds",
            lambda t: str(round(t * 1e9)),
            ":7: time 1000000000.000000 s is on another clock than line 1's 0.000000 s (allowed: every stamp since the "
            "robot's start, below 1e+09 s, or every stamp on the export's clock, since 1970); the file's stamps look "
            "like nanoseconds since the start",
        ),
        (
            "50 ms late",
            lambda t: f"{t + 0.05:.9f}",
            ":1: time 0.050000 s of robot a matches no frame within 0.01 s (nearest frame 0.000000 s, 0.050000 s "
            "before it; the robot's frames run 0.000000 to 89.166667 s, every 0.166667 s; the file's clock: seconds "
            "since the robot's start)",
        ),
        (
            "nanoseconds since 1970",
            lambda t: str(EXPORT_EPOCH_NS + round(t * 1e9)),
            ":1: field timestamp: 1.7e+18 s is out of range (allowed: a magnitude of at most 1e+11 s); it looks like "
            "nanoseconds (times here are seconds)",
        ),
    ],
)
def test_trajectories_that_match_no_frame_fail_in_one_line(
    smoke_run: RunResult,
    closures: list[Closure],
    tmp_path: Path,
    cli_fails: Callable[..., str],
    case: str,
    stamp: Callable[[float], str],
    message: str,
) -> None:
    traj = _trajectories(smoke_run, tmp_path / "traj", stamp)
    write_csv_closures(tmp_path / "c.csv", closures)
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "-c", tmp_path / "c.csv", "-t", traj, "-o", out)
    assert err == f"error: {traj / 'a.tum'}{message}"
    assert not out.exists()


def test_a_denser_trajectory_needs_a_pose_at_every_frame(
    smoke_run: RunResult, closures: list[Closure], tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    """A trajectory with more poses than frames (as at an IMU's rate) is matched frame by frame."""
    traj = tmp_path / "traj"
    traj.mkdir()
    for r in ("a", "b"):
        tr = read_tum(smoke_run.run_dir / "trajectories" / f"{r}.roman.tum")
        t = np.sort(np.concatenate([tr.t, tr.t[:-1] + 0.08]))  # two poses a frame
        rows = [f"{x:.9f} 0 0 0 0 0 0 1" for x in t]
        if r == "b":
            rows = [row for row, x in zip(rows, t) if not 30.0 - 1e-6 < x < 30.2]  # no pose near b's frame at 30 s
        (traj / f"{r}.tum").write_text("\n".join(rows) + "\n", encoding="utf-8")
    write_csv_closures(tmp_path / "c.csv", closures)
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "-c", tmp_path / "c.csv", "-t", traj, "-o", out)
    assert err == (
        f"error: {traj / 'b.tum'}: no pose within 0.01 s of robot b's frame at 30.000000 s (a trajectory with more "
        "poses than the robot has frames needs one at every frame it spans; the file's clock: seconds since the "
        "robot's start)"
    )
    assert not out.exists()
