"""The committed reports are in the current layout: rewriting one from its folder's files changes nothing."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from committed_results import REFERENCE as REF
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.errors import StorageError
from roman_sim.studies.reference import rewrite_report


def _files(d: Path) -> dict[str, bytes]:
    return {p.relative_to(d).as_posix(): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("name", ["demo", "opposite_direction"])
def test_rewriting_a_committed_report_gives_its_bytes_and_touches_nothing_else(name: str, tmp_path: Path) -> None:
    if not (REF / name / "report.md").is_file():
        pytest.skip("no committed reference run")
    copy = tmp_path / name
    shutil.copytree(REF / name, copy)
    (copy / "report.md").write_text(
        "# Evaluation report: stale\n\n## Notes\n\n"
        + "".join(f"- {n}\n" for n in _notes(REF / name / "report.md"))
        + "\nPlots not kept in the reference results (any run draws them): "
        + _not_kept(REF / name / "report.md")
        + ".\n"
    )
    res = CliRunner().invoke(app, ["report", str(copy), "--rewrite"])
    assert res.exit_code == 0, res.output
    assert _files(copy) == _files(REF / name)


def _notes(report: Path) -> list[str]:
    text = report.read_text(encoding="utf-8").split("## Notes\n\n", 1)[1].split("\n\n", 1)[0]
    return [ln[2:] for ln in text.splitlines()]


def _not_kept(report: Path) -> str:
    marker = "Plots not kept in the reference results (any run draws them): "
    line = next(ln for ln in report.read_text(encoding="utf-8").splitlines() if ln.startswith(marker))
    return line[len(marker) : -1]


def test_the_demo_report_opens_with_its_paragraph() -> None:
    if not (REF / "demo" / "report.md").is_file():
        pytest.skip("no committed reference run")
    lines = (REF / "demo" / "report.md").read_text(encoding="utf-8").splitlines()
    assert lines[2].startswith("**Cross-robot pairs, 44 relevant.** At max recall roman leads with 0.68 (30/44)")
    assert lines[4] == "## Headline plots"


def test_rewrite_needs_a_collected_run(tmp_path: Path) -> None:
    with pytest.raises(StorageError, match="not a collected run folder .report.md and metrics.json are needed."):
        rewrite_report(tmp_path)
