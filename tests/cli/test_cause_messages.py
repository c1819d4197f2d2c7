"""Messages that name the cause, not the symptom: a memory cap, a world with nothing to align.

Each case is pinned to its exact text.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from roman_sim.cli import app

pytestmark = pytest.mark.timeout(300)
MICRO = ["--set", "robots.0.max_length_m=12", "--set", "robots.1.max_length_m=12"]
CAP = "address space limited to 586 MB (ulimit -v)"
NO_SEGMENTS = (
    "no submap holds a segment (a world without objects, or none mapped): no method had anything to align, "
    "so every method's recall, precision and F1 are undefined, not 0"
)


@pytest.fixture
def capped(monkeypatch: pytest.MonkeyPatch) -> None:
    """The CLI sees a 600000 KiB address-space cap (the cap itself is not set: this process keeps its memory)."""
    from roman_sim.cli import _signals

    monkeypatch.setattr(_signals, "memory_limit_note", lambda: CAP)


EGL = "Cannot initialize a EGL device display. This likely means that your EGL driver does not ..."


def _egl_fails(*_: object) -> object:
    raise ImportError(EGL)


def _pool_reports_egl(*_: object) -> object:
    """What a pool worker's failure comes back as (``TaskError``, a ``RomanSimError``)."""
    from roman_sim.runner.executor_base import TaskError

    raise TaskError(f"mapping robot a failed on worker 1: ImportError: {EGL}")


@pytest.mark.parametrize(
    ("task", "what"),
    [
        (_egl_fails, f"ImportError: {EGL}"),
        (_pool_reports_egl, f"mapping robot a failed on worker 1: ImportError: {EGL}"),
    ],
    ids=["in-this-process", "from-a-worker"],
)
def test_under_a_memory_cap_the_line_starts_with_the_cap_and_the_stage_whatever_failed(
    task: object, what: str, capped: None, monkeypatch: pytest.MonkeyPatch, tmp_path: Path, cli_fails
) -> None:
    """The renderer cannot map its device under the cap: the line leads with the cap, then the stage."""
    from roman_sim.pipeline.stages import maps

    monkeypatch.setattr(maps, "map_one", task)
    run = tmp_path / "run"
    line = cli_fails("run", "smoke", *MICRO, "--executor", "serial", "--out", run, allow_progress=True)
    assert line == f"error: {CAP}: failed in stage maps: {what} (no stage completed in {run})"


def test_a_world_without_objects_says_so_once_and_leaves_every_figure_undefined(tmp_path: Path) -> None:
    smoke = yaml.safe_load((Path(__file__).resolve().parents[2] / "roman_sim/scenarios/smoke.yaml").read_text())
    smoke["name"] = "empty"
    smoke["world"]["overrides"] = {f"families.{i}.density": 0 for i in range(6)}
    path = tmp_path / "empty.yaml"
    path.write_text(yaml.safe_dump(smoke))
    run = tmp_path / "run"
    res = CliRunner().invoke(app, ["run", str(path), *MICRO, "--executor", "serial", "--out", str(run)])
    assert res.exit_code == 0, res.output
    printed = " ".join(res.stdout.split())  # the console wraps at its width
    assert printed.count(NO_SEGMENTS) == 1  # the lead line, in place of figures
    assert f"Cross-robot pairs, 1 relevant. Undefined: {NO_SEGMENTS}." in printed
    assert "0/1" not in printed and "undefined" in printed
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["notes"] == [NO_SEGMENTS]  # one line, instead of a failure line per method
    assert metrics["n_relevant"] >= 1  # pairs are relevant by distance: the figures are undefined, not 0 of them
    report = (run / "report.md").read_text()
    assert f"**Cross-robot pairs, 1 relevant.** Undefined: {NO_SEGMENTS}.\n" in report
    assert f"- {NO_SEGMENTS}\n" in report
    assert f"## Alignment, cross-robot pairs (headline)\n\nUndefined: {NO_SEGMENTS}.\n" in report
    verify = CliRunner().invoke(app, ["report", str(run), "--verify"])
    assert verify.exit_code == 0, verify.output
