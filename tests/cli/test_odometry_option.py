"""``roman-sim run SCENARIO --odometry ROBOT=FILE.tum`` (``roman_sim.cli``): a bad file is one line, exit code 1,
nothing written."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import format_tum

#: The smoke scenario cut to 5 s per robot: frames at 0, 1/6, ..., 5 s (31 of them).
SHORT = ["--set", "robots.0.max_duration_s=5", "--set", "robots.1.max_duration_s=5"]
TIMES = np.arange(31) / 6.0


def _tum(path: Path, t: np.ndarray) -> Path:
    T = np.tile(np.eye(4), (len(t), 1, 1))
    T[:, 0, 3] = 0.2 * np.arange(len(t))  # 1.2 m/s
    path.write_text(format_tum(Trajectory(t, T)))
    return path


@pytest.mark.parametrize(
    ("robot", "stamps", "expect"),
    [
        ("c", TIMES, "--odometry c={file}: no robot c (robots: a, b)"),
        (
            "a",
            TIMES[:15],
            "{file}: covers 48% of robot a's frames (15 of 31 within 0.01 s; the file runs 0.000 to "
            "2.333 s, the robot 0.000 to 5.000 s); required: at least 90% (odometry.min_share)",
        ),
        (
            "a",
            TIMES + np.where(np.arange(31) == 2, 0.05, 0.0),
            "{file}:3: time 0.383333 s of robot a matches no frame within 0.01 s (nearest frame 0.333333 s",
        ),
        ("b", TIMES * 1e9, "{file}:31: time 5000000000 is in nanoseconds (5.000000 s, within the robot's drive)"),
    ],
    ids=["unknown robot", "too little of the drive", "a stamp on no frame", "nanoseconds"],
)
def test_a_bad_odometry_file_is_one_line_and_nothing_is_written(
    cli_fails: Callable[..., str], tmp_path: Path, robot: str, stamps: np.ndarray, expect: str
) -> None:
    file = _tum(tmp_path / "odom.tum", stamps)
    line = cli_fails("run", "smoke", *SHORT, "--odometry", f"{robot}={file}", "--out", tmp_path / "out")
    assert expect.format(file=file) in line, line
    assert not (tmp_path / "out").exists()


def test_an_odometry_value_names_a_robot_and_a_file(cli_fails: Callable[..., str], tmp_path: Path) -> None:
    line = cli_fails("run", "smoke", "--odometry", "a.tum", "--out", tmp_path / "out")
    assert line == "error: --odometry a.tum: expected ROBOT=FILE.tum (a robot's name and a TUM file)"
    line = cli_fails("run", "smoke", "--odometry", f"a={tmp_path / 'none.tum'}", "--out", tmp_path / "out")
    assert f"odometry.file {tmp_path / 'none.tum'}: cannot be read" in line
    assert not (tmp_path / "out").exists()
