"""Messages that name the right thing: the field of the file, the missing folder, the corrupt file.

Each case is pinned to its exact line.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from committed_results import STANDARD, copy_committed
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.errors import SimError

pytestmark = pytest.mark.timeout(300)
MICRO = ["--set", "robots.0.max_length_m=6", "--set", "robots.1.max_length_m=6"]


def _scenario(tmp_path: Path, overrides: dict[str, object]) -> Path:
    path = tmp_path / "bad.yaml"
    world = {"preset": "tiny", "overrides": overrides}
    path.write_text(yaml.safe_dump({"name": "bad", "world": world, "robots": [{"name": "a"}]}))
    return path


@pytest.mark.parametrize(
    ("overrides", "expect"),
    [
        (
            {"families.9.density": 3},
            "families.9.density: position 9 out of range: families has 6 entries (positions: 0..5)",
        ),
        (
            {"families.first.density": 3},
            "families.first.density: families is a list of 6 entries, 'first' is not a position in it "
            "(positions: 0..5)",
        ),
        (
            {"extent_m.0.x": 3},
            "extent_m.0.x: extent_m.0 is a number (40.0), not a mapping or list, so it has no 'x'",
        ),
    ],
)
def test_a_bad_world_overrides_key_in_a_scenario_file_names_world_overrides(
    tmp_path: Path, overrides: dict[str, object], expect: str, cli_fails
) -> None:
    line = cli_fails("run", _scenario(tmp_path, overrides), "--out", tmp_path / "run")
    assert line == f"error: world.overrides (tiny): {expect}"


def test_the_same_bad_key_on_the_command_line_is_still_named_as_set(tmp_path: Path, cli_fails) -> None:
    line = cli_fails("world", "generate", "tiny", "--set", "families.9.density=3", "--out", tmp_path / "w")
    assert line == "error: --set families.9.density: position 9 out of range: families has 6 entries (positions: 0..5)"


def test_world_preview_of_a_missing_folder_says_the_folder_is_missing(tmp_path: Path, cli_fails) -> None:
    missing = tmp_path / "exported" / "world"
    line = cli_fails("world", "preview", missing, "--out", tmp_path / "p.png")
    assert line == (
        f"error: world preview {missing}: no such folder (an exported world folder holds world.xml, truth.json "
        "and spec.yaml; or give a world YAML or a preset: forest, offroad, orchard, park, parking, suburb, tiny)"
    )
    assert not (tmp_path / "p.png").exists()


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("finished") / "run"
    res = CliRunner().invoke(app, ["run", "smoke", *MICRO, "--executor", "serial", "--out", str(out)])
    assert res.exit_code == 0, res.output
    return out


def test_report_on_a_corrupt_result_file_names_the_file(finished_run: Path, tmp_path: Path, cli_fails) -> None:
    run = tmp_path / "run"
    shutil.copytree(finished_run, run)
    (run / "ate.json").write_text("{garbage")
    assert cli_fails("report", run) == (
        f"error: {run / 'ate.json'}: not valid JSON (line 1: Expecting property name enclosed in double quotes)"
    )
    shutil.copy(finished_run / "ate.json", run / "ate.json")
    (run / "metrics.json").write_text("[1")
    assert (
        cli_fails("report", run) == f"error: {run / 'metrics.json'}: not valid JSON (line 1: Expecting ',' delimiter)"
    )


def test_report_on_a_run_without_its_config_yaml_says_so(finished_run: Path, tmp_path: Path, cli_fails) -> None:
    run = tmp_path / "run"
    shutil.copytree(finished_run, run)
    (run / "config.yaml").unlink()
    assert cli_fails("report", run) == (
        f"error: {run}: the run's config.yaml is missing (deleted after the run?); "
        "run the scenario into this folder again to rewrite it"
    )


def test_env_reset_rejects_unknown_options_and_non_dict_options_and_stays_usable() -> None:
    from roman_sim.sim.env import GroundRobotEnv
    from roman_sim.sim.kinematics import PlanarState, body_pose_on_terrain

    env = GroundRobotEnv(camera={"width": 32, "height": 24}, render_rgb=False, max_steps=3)
    try:
        with pytest.raises(SimError) as err:
            env.reset(seed=0, options={"bogus": 1})
        assert str(err.value) == "GroundRobotEnv: unknown reset option 'bogus' (valid: start)"
        with pytest.raises(SimError) as err:
            env.reset(options="start")  # type: ignore[arg-type]
        assert str(err.value) == "GroundRobotEnv: reset options must be a dict (keys: start), got str 'start'"
        with pytest.raises(SimError, match=r"^GroundRobotEnv: start \(1e\+06, 0\) lies outside the world"):
            env.reset(options={"start": (1e6, 0.0, 0.0)})
        _, random_start = env.reset(seed=0)
        _, chosen = env.reset(seed=0, options={"start": (0.0, 0.0, 0.5)})
        pose = body_pose_on_terrain(env.world.truth.terrain, PlanarState(0.0, 0.0, 0.5), env.body_height_m)
        np.testing.assert_array_equal(chosen["T_world_body"], pose)
        _, again = env.reset(seed=0, options={"start": None})  # None: a random start, as without options
        np.testing.assert_array_equal(again["T_world_body"], random_start["T_world_body"])
        env.step(np.array([1.0, 0.0]))  # usable after the rejected resets
    finally:
        env.close()


def test_a_damaged_benchmark_cell_record_names_the_file_and_field(tmp_path: Path, cli_fails) -> None:
    out = tmp_path / "standard"
    copy_committed(STANDARD, out)
    cell = out / "cells" / "low-s0" / "cell.json"
    cell.write_text(cell.read_text().replace('"status": "ok"', '"status": "done"'))
    assert cli_fails("benchmark", "standard", "--out", out, "--report-only") == (
        f"error: {cell}: field status: expected one of 'ok', 'failed', got a string ('done')"
    )


def test_a_damaged_paper_fit_state_names_the_file_and_field(tmp_path: Path, cli_fails) -> None:
    out = tmp_path / "fit"
    out.mkdir()
    state = out / "fit_state.json"
    state.write_text('{"config": {}, "runs": {"0.000000": {"roman": "high"}}}')
    assert cli_fails("paper-preset", "fit", "--out", out) == (
        f"error: {state}: field runs.0.000000.roman: expected a number, got a string ('high') "
        "(not a paper-fit state file; remove it to start again)"
    )
