"""The small things a first-hour user trips on: each an exact message or behaviour."""

from __future__ import annotations

import importlib.util
from importlib.metadata import version
from pathlib import Path

import pytest
from typer.testing import CliRunner

from roman_sim.cli import app


def test_version_prints_the_package_version() -> None:
    res = CliRunner().invoke(app, ["--version"])
    assert res.exit_code == 0 and res.stdout == f"roman-sim {version('roman_sim')}\n"


def test_view_without_the_interop_extra_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "rerun" else real(name, *a))
    res = CliRunner().invoke(app, ["view", str(tmp_path)])
    assert res.exit_code == 1
    assert (
        res.stderr
        == "error: roman-sim view needs the rerun SDK of the interop extra: pip install 'roman_sim[interop]'\n"
    )


def test_a_bare_benchmark_runs_the_quick_suite() -> None:
    res = CliRunner().invoke(app, ["benchmark", "--help"], env={"COLUMNS": "200"})
    assert "quick (the default, minutes), standard (about 80 min on 2 cores)" in res.stdout
    assert "[default: quick]" in res.stdout


@pytest.mark.parametrize(
    ("sets", "expect"),
    [
        (["seed=abc"], "error: --set seed=abc: seed: Input should be a valid integer, unable to parse string as an"),
        (
            ["seed=2", "world.nonexistent=3"],
            "error: --set world.nonexistent=3: world.nonexistent: unknown key (allowed:",
        ),
    ],
)
def test_a_bad_set_value_names_the_flag_not_the_bundled_file(tmp_path: Path, sets: list[str], expect: str) -> None:
    args = ["run", "smoke", "--out", str(tmp_path / "out")] + [x for s in sets for x in ("--set", s)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 1 and res.stderr.startswith(expect) and "smoke.yaml" not in res.stderr
    assert res.stderr.count("\n") == 1


def test_flags_show_plainly_in_help() -> None:
    res = CliRunner().invoke(app, ["--help"], env={"COLUMNS": "120"})
    assert "<bool>" not in res.stdout and "--verbose  -v " in res.stdout
    run = CliRunner().invoke(app, ["run", "--help"], env={"COLUMNS": "120"})
    assert "<bool>" not in run.stdout and "<int>" in run.stdout  # options with a value keep their type
