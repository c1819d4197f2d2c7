"""``-v`` / ``--debug``: the one-line error, then the full traceback of its cause (a plug-in's own line)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from roman_sim.cli import app

BAD = """class Bad:
    name = "bad"

    def align(self, a, b):
        return 1 / 0
"""
LINE = "error: aligner 'badaligner:Bad': the check on two synthetic submaps raised ZeroDivisionError: division by zero"


@pytest.fixture
def plugin_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "badaligner.py").write_text(BAD)
    (tmp_path / "brokenmod.py").write_text("import json\n\nVALUE = json.loads('{not json')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    yield tmp_path
    for name in ("badaligner", "brokenmod"):
        sys.modules.pop(name, None)


@pytest.mark.parametrize("flag", ["-v", "--debug"])
def test_a_plugin_error_shows_the_plugins_line_when_asked(plugin_dir: Path, flag: str) -> None:
    args = ["run", "smoke", "--aligner", "badaligner:Bad", "--out", str(plugin_dir / "out")]
    plain = CliRunner().invoke(app, args)
    assert plain.exit_code == 1 and plain.stderr.strip() == LINE  # one line without the flag
    asked = CliRunner().invoke(app, [flag, *args])
    assert asked.exit_code == 1
    lines = asked.stderr.splitlines()
    assert lines[0] == LINE and lines[1] == "Traceback (most recent call last):"
    bug = f'  File "{plugin_dir / "badaligner.py"}", line 5, in align'
    assert bug in lines and "    return 1 / 0" in lines
    assert lines.index(bug) < lines.index("which was reported as:")
    assert asked.stderr.rstrip().endswith(LINE.replace("error: ", "roman_sim.core.errors.PluginError: "))


def test_an_import_error_of_a_plugin_module_shows_its_cause(plugin_dir: Path) -> None:
    args = ["--debug", "run", "smoke", "--aligner", "brokenmod:Anything", "--out", str(plugin_dir / "out")]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 1 and res.stderr.startswith("error: aligner 'brokenmod:Anything'")
    assert f'  File "{plugin_dir / "brokenmod.py"}", line 3, in <module>' in res.stderr.splitlines()
    assert "json.decoder.JSONDecodeError: Expecting property name enclosed in double quotes" in res.stderr


#: Passes the dry call (two submaps of different robots, index 0) and raises on the run's pairs.
LATE = """class Late:
    name = "late"

    def align(self, a, b):
        from roman_sim.align.base import AlignResult

        if a.index == 0 and b.index == 0 and a.robot != b.robot:
            return AlignResult.failure("late", "declines")
        raise KeyError("segment 17")
"""
#: Both robots stop after 12 m: a few submaps, a run of seconds.
MICRO = ["--set", "robots.0.max_length_m=12", "--set", "robots.1.max_length_m=12"]


@pytest.mark.timeout(300)
@pytest.mark.parametrize(
    "executor",
    [["--executor", "serial"], ["--executor", "local", "--workers", "2"], ["--executor", "dask", "--workers", "1"]],
    ids=["serial", "local", "dask"],
)
def test_a_plugin_failing_inside_a_stage_shows_its_line_on_every_executor(
    plugin_dir: Path, executor: list[str]
) -> None:
    """The plug-in raises in a task of the evaluation stage, on a worker process (local pool, Dask) or here."""
    (plugin_dir / "lateplug.py").write_text(LATE)
    args = ["run", "smoke", *MICRO, "--aligner", "lateplug:Late", "--out", str(plugin_dir / "out"), *executor]
    plain = CliRunner().invoke(app, args)
    assert plain.exit_code == 1 and "Traceback" not in plain.stderr, plain.output
    one_line = re.compile(
        r"error: (aligning pairs \d+\.\.\d+ failed on worker tcp://127\.0\.0\.1:\d+: )?aligner 'lateplug:Late' "
        r"failed on pair \w/\d+ - \w/\d+: KeyError: 'segment 17' \(completed stages kept in .*: maps, submaps\)"
    )
    assert one_line.fullmatch(plain.stderr.strip().splitlines()[-1]), plain.stderr
    asked = CliRunner().invoke(app, ["--debug", *args])  # the maps are kept: only the evaluation runs again
    assert asked.exit_code == 1
    lines = asked.stderr.splitlines()
    (line,) = [x for x in lines if one_line.fullmatch(x)]  # the one line, then the tracebacks
    bug = f'  File "{plugin_dir / "lateplug.py"}", line 9, in align'
    assert lines[lines.index(line) + 1] == "Traceback (most recent call last):"
    assert bug in lines and lines[lines.index(bug) + 1] == '    raise KeyError("segment 17")'
    assert lines.index(line) < lines.index(bug) < lines.index("which was reported as:")
    assert lines.count(bug) == 1  # the worker's tracebacks once, not again through the pool's own copy
    assert asked.stderr.rstrip().endswith(line.split("error: ", 1)[1])
