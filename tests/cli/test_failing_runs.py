"""Failures during a run: plug-ins that break on real data, a sweep cell that fails, Ctrl-C.

Each ends in one line naming what failed (plug-in, pair or frame, exception), keeps the
completed stages, and a run that did not finish is never reported as finished. The runs
are the smoke scenario with both robots stopping after 12 m (a few seconds each).
"""

from __future__ import annotations

import csv
import json
import signal
from pathlib import Path

import pytest
import yaml
from processes import cli, start, tagged, tagged_env, wait_gone
from typer.testing import CliRunner

from roman_sim.cli import app

pytestmark = pytest.mark.timeout(300)
MICRO = ["--set", "robots.0.max_length_m=12", "--set", "robots.1.max_length_m=12"]


def _invoke(*args: object) -> tuple[int, str, str]:
    res = CliRunner().invoke(app, [str(a) for a in args])
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    return res.exit_code, res.stdout, res.stderr


def _stages(run_dir: Path) -> list[str]:
    return sorted(json.loads((run_dir / "manifest.json").read_text())["stages"])


def test_aligner_failing_on_a_real_pair_names_it_and_keeps_the_front_end(home: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    code, _, err = _invoke("run", "smoke", *MICRO, "--aligner", "user_plugins:FailsOnRealPairs", "--out", out)
    lines = err.strip().splitlines()
    assert code == 1 and "Traceback" not in err
    # stderr is not a terminal here: one line per finished stage, then the error
    assert all(line.startswith("stage ") and ": done (" in line for line in lines[:-1]), err
    assert {"stage maps: done", "stage submaps: done"} <= {line.split(" (")[0] for line in lines[:-1]}
    assert lines[-1].startswith("error: aligner 'user_plugins:FailsOnRealPairs' failed on pair ")
    assert lines[-1].endswith(f"KeyError: 'segment 17' (completed stages kept in {out}: maps, submaps)")
    assert _stages(out) == ["maps", "submaps"]
    code, _, err = _invoke("report", out)  # not reported as finished
    assert code == 1 and err.strip() == (
        f"error: {out}: the run did not complete (stages missing: evaluation, "
        "posegraph, ate, report); run it again to finish it"
    )
    code, _, err = _invoke("run", "smoke", *MICRO, "--out", out)  # without the plug-in: the front end is reused
    assert code == 0, err
    timings = json.loads((out / "timings.json").read_text())["stages"]
    assert timings["maps"]["reused"] and timings["submaps"]["reused"] and not timings["evaluation"]["reused"]


def test_segmenter_failing_on_a_later_frame_names_the_frame(home: Path, tmp_path: Path, cli_fails) -> None:
    line = cli_fails(
        "run",
        "smoke",
        *MICRO,
        "--set",
        "frontend.segmenter=user_plugins:FailsOnLaterFrames",
        "--out",
        tmp_path / "run",
        allow_progress=True,
    )
    assert line == (
        "error: segmenter 'user_plugins:FailsOnLaterFrames' failed on frame 3 of robot a: "
        f"MemoryError: CUDA out of memory (no stage completed in {tmp_path / 'run'})"
    )


def test_a_failing_sweep_cell_is_recorded_and_the_sweep_exits_1(home: Path, tmp_path: Path) -> None:
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(
        yaml.safe_dump(
            {
                "name": "mixed",
                "scenario": "smoke",
                "seeds": [0],
                "grid": {
                    "frontend.segmenter": ["perfect", "user_plugins:FailsOnLaterFrames"],
                    "robots.0.max_length_m": [12.0],
                    "robots.1.max_length_m": [12.0],
                },
            }
        )
    )
    code, out, err = _invoke("sweep", sweep, "--out", tmp_path / "sw")
    assert code == 1 and "Traceback" not in err
    rows = list(csv.DictReader((tmp_path / "sw" / "sweep.csv").open()))
    ok = [r for r in rows if r["status"] == "ok"]
    failed = [r for r in rows if r["status"] == "failed"]
    assert {r["method"] for r in ok} == {"roman", "clipper"} and {r["frontend.segmenter"] for r in ok} == {"perfect"}
    assert len(failed) == 1 and failed[0]["frontend.segmenter"] == "user_plugins:FailsOnLaterFrames"
    assert failed[0]["error"].startswith(
        "segmenter 'user_plugins:FailsOnLaterFrames' failed on frame 3 of robot a: MemoryError: CUDA out of memory"
    )
    assert "1 sweep run(s) failed" in err and failed[0]["run_id"] in err
    assert "sweep mixed: 2/2 runs done" in err and "sweep table:" in out


def test_any_exception_in_a_cell_is_that_cells_failure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Even an exception that is not the package's (a bug) is recorded, and the other cells still run."""
    import roman_sim.pipeline.experiment as experiment
    from roman_sim.pipeline.sweep import SweepConfig, run_sweep, sweep_failures

    calls: list[int] = []

    def fake_run(path: str, overrides: list[str], run_dir: Path, from_stage: str | None = None) -> object:
        calls.append(1)
        if "seed=1" in overrides:
            raise ZeroDivisionError("division by zero")
        raise RecursionError("maximum recursion depth exceeded")

    monkeypatch.setattr(experiment, "run_scenario_file", fake_run)
    cfg = SweepConfig(name="s", scenario="smoke", seeds=[0, 1])
    table = run_sweep(cfg, Path("smoke"), tmp_path)
    failed = sweep_failures(table)
    assert len(calls) == 2
    assert [(r.seed, r.status, r.error) for r in failed] == [
        ("0", "failed", "RecursionError: maximum recursion depth exceeded"),
        ("1", "failed", "ZeroDivisionError: division by zero"),
    ]


def test_ctrl_c_keeps_completed_stages_and_exits_130(plugin_home: Path, tmp_path: Path) -> None:
    out = tmp_path / "run"
    env, tag = tagged_env(PATH="")
    cmd = cli("run", "smoke", *MICRO, "--aligner", "user_plugins:SlowOnRealPairs", "--out", str(out))
    proc = start(cmd, env, plugin_home)
    seen = []
    assert proc.stderr is not None
    for line in proc.stderr:  # interrupt in the evaluation, where every pair takes 2 s
        seen.append(line)
        if line.startswith("stage submaps: done"):
            break
    proc.send_signal(signal.SIGINT)
    _, rest = proc.communicate(timeout=120)
    err = "".join(seen) + rest
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == (
        f"interrupted: completed stages kept in {out}: maps, submaps; run the same command again to resume"
    )
    man = json.loads((out / "manifest.json").read_text())
    assert not man["complete"] and sorted(man["stages"]) == ["maps", "submaps"]
    assert not wait_gone(lambda: tagged(tag))  # the pool's workers were ended with their 2 s pairs
