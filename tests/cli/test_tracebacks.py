"""``-v`` / ``--debug``: the one-line error, then the full traceback of its cause (a plug-in's own line)."""

from __future__ import annotations

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
