"""``roman-sim score`` on an export folder: its scenario is run for the submaps, then the closures are scored."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import inv_T
from roman_sim.core.tum import read_tum
from roman_sim.evaluation.results import read_evaluation
from roman_sim.interop.closures import Closure, write_csv_closures
from roman_sim.pipeline.scenario import Scenario
from roman_sim.scoring.external import read_external, score_external


def test_score_an_export_folder(tum_export: Path, tiny_scenario: Scenario, tmp_path: Path) -> None:
    """A perfect closure between the robots' first frames (submap centres) scores as correct."""
    truth = {r: read_tum(tum_export / r / "groundtruth_body.txt") for r in ("a", "b")}
    T = inv_T(truth["a"].T[0]) @ truth["b"].T[0]
    wrong = T @ np.diag([-1.0, -1.0, 1.0, 1.0])  # turned by 180 degrees about z
    closures = [Closure("a", 0.0, "b", 0.0, T, 9), Closure("b", 0.0, "a", 2.0, inv_T(wrong), 2)]
    write_csv_closures(tmp_path / "c.csv", closures)
    res = score_external(tum_export, tmp_path / "c.csv", tmp_path / "scored", label="perfect")
    scores = {(s.truth.a, s.truth.b): s for s in read_evaluation(tmp_path / "scored")[0]}
    hit = scores[("a/0", "b/0")]
    assert hit.method == "perfect" and hit.n_assoc == 9 and hit.correct
    # the odometry starts at the body's tilted start pose, so its gravity-aligned submap frame
    # differs from the true one by the start tilt (well under a degree on this ground)
    assert hit.rot_err_deg < 1.0 and hit.trans_err_m < 1e-6
    assert all(s.n_assoc == 0 for k, s in scores.items() if k != ("a/0", "b/0"))
    info = read_external(tmp_path / "scored")
    assert info.n_closures == 2 and res.n_pairs == 1
    (why,) = info.unscored.values()  # the second closure falls on the same pair with a lower score
    assert "already has a closure with a score >= 2" in str(why) or "both ends" in str(why)
    config = json.loads(json.dumps(res.run.scenario.model_dump(mode="json")))
    assert config["aligners"][0]["label"] == "perfect" and config["seed"] == tiny_scenario.seed


def test_an_export_scored_with_a_flag_that_makes_things_worse_leaves_nothing(
    tum_export: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The export's maps are computed into --out before the check: the error removes them again."""
    from roman_sim.scoring import closure_conventions

    monkeypatch.setattr(closure_conventions, "FAR_GAIN", 1)  # one correct pair is "far better" than none here
    truth = {r: read_tum(tum_export / r / "groundtruth_body.txt") for r in ("a", "b")}
    write_csv_closures(tmp_path / "c.csv", [Closure("a", 0.0, "b", 0.0, inv_T(truth["a"].T[0]) @ truth["b"].T[0], 9)])
    with pytest.raises(
        ConfigError,
        match=r"^--invert-edges makes .*c.csv score worse: 0 of 1 estimated pairs correct "
        r"with --invert-edges, 1 of 1 estimated pairs correct as read \(drop --invert-edges\)$",
    ):
        score_external(tum_export, tmp_path / "c.csv", tmp_path / "scored", invert_edges=True)
    assert not (tmp_path / "scored").exists()
    (tmp_path / "empty").mkdir()  # a folder that was there and empty stays, emptied
    with pytest.raises(ConfigError):
        score_external(tum_export, tmp_path / "c.csv", tmp_path / "empty", invert_edges=True)
    assert list((tmp_path / "empty").iterdir()) == []


def test_a_file_in_an_unknown_format_is_one_line(
    tum_export: Path, tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    (tmp_path / "c.json").write_text("[]", encoding="utf-8")
    (tmp_path / "c.csv").write_text("timestamp,x,y,z\n0,1,2,3\n", encoding="utf-8")
    out = tmp_path / "out"
    err = cli_fails("score", tum_export, "-c", tmp_path / "c.json", "-o", out)
    assert err == (
        f"error: --closures {tmp_path / 'c.json'}: unknown file type '.json' (allowed: a .csv file (this testbed's "
        "closures or Kimera-Multi's loop_closures.csv), a .g2o file (gtsam Symbol keys, or the reference ROMAN's "
        "per-pair align.g2o), the reference's align folder, or a folder of Kimera-Multi's logs)"
    )
    err = cli_fails("score", tum_export, "-c", tmp_path / "c.csv", "-o", out)
    assert err.startswith(f"error: {tmp_path / 'c.csv'}:1: unknown CSV header 'timestamp,x,y,z' (allowed: ")
    assert not out.exists()


def test_swapped_robots_whose_stamps_match_no_frame_are_named(
    tum_export: Path, tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    """Robot a drives 3 s, b 1 s: a closure at a's 2 s written as b's matches no frame of b, but swapped it does."""
    write_csv_closures(tmp_path / "c.csv", [Closure("b", 2.0, "a", 0.0, np.eye(4), 5)])
    out = tmp_path / "out"
    err = cli_fails("score", tum_export, "-c", tmp_path / "c.csv", "-o", out)
    assert err == (
        f"error: {tmp_path / 'c.csv'}:2: time 2.000000 s of robot b matches no frame within 0.01 s (nearest frame "
        "1.000000 s, 1.000000 s before it; the robot's frames run 0.000000 to 1.000000 s, every 0.166667 s; the file's "
        "clock: seconds since the robot's start); with --swap-robots every closure matches a frame"
    )
    assert not out.exists()
