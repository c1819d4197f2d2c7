"""Every command's output path checked first (``roman_sim.cli``): a folder option naming a file, or a file option naming
a folder, is one line and exit code 1 before any work, and the file or folder there is left as it was."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SWEEP = ROOT / "scenarios" / "sweeps" / "opposite_seeds.yaml"

#: command (``{file}``: an existing file, ``{dir}``: an existing folder, ``{src}``: an export folder) -> the option
FOLDER_OPTIONS = {
    "score": (["score", "{src}", "-c", "{src}/c.csv", "--out", "{file}"], "--out"),
    "run": (["run", "smoke", "--out", "{file}"], "--out"),
    "demo": (["demo", "--out", "{file}"], "--out"),
    "record": (["record", "smoke", "--out", "{file}"], "--out"),
    "export": (["export", "smoke", "-f", "tum", "--out", "{file}"], "--out"),
    "sweep": (["sweep", str(SWEEP), "--out", "{file}"], "--out"),
    "reproduce --out": (["reproduce", "--out", "{file}", "--scenario", "smoke"], "--out"),
    "reproduce --work": (["reproduce", "--out", "{dir}", "--work", "{file}", "--scenario", "smoke"], "--work"),
    "tune": (["tune", "smoke", "--out", "{file}"], "--out"),
    "paper-preset fit": (["paper-preset", "fit", "--out", "{file}"], "--out"),
    "study attribution --out": (["study", "attribution", "--out", "{file}"], "--out"),
    "study attribution --results": (
        ["study", "attribution", "--out", "{dir}", "--results", "{file}"],
        "--results",
    ),
    "world generate": (["world", "generate", "offroad", "--out", "{file}"], "--out"),
}
FILE_OPTIONS = {
    "view": (["view", "{dir}", "--out", "{dir}"], "--out"),
    "calibrate --out": (["calibrate", "smoke", "--encoder", "clip", "--out", "{dir}"], "--out"),
    "calibrate --grades": (
        ["calibrate", "smoke", "--encoder", "clip", "--out", "{file}", "--grades", "{dir}"],
        "--grades",
    ),
    "scenario stats": (["scenario", "stats", "smoke", "--out", "{dir}"], "--out"),
}


@pytest.fixture
def paths(tmp_path: Path) -> dict[str, Path]:
    src = tmp_path / "export"
    src.mkdir()
    (src / "export.json").write_text("{}", encoding="utf-8")
    (src / "c.csv").write_text("a,0,b,1,0,0,0,0,0,0,1,5\n", encoding="utf-8")
    (tmp_path / "notes.txt").write_text("mine\n", encoding="utf-8")
    (tmp_path / "kept").mkdir()
    (tmp_path / "kept" / "x.txt").write_text("x\n", encoding="utf-8")
    return {"file": tmp_path / "notes.txt", "dir": tmp_path / "kept", "src": src}


def _args(template: list[str], paths: dict[str, Path]) -> list[str]:
    return [a.format(**{k: str(v) for k, v in paths.items()}) for a in template]


NOT_A_FOLDER = "error: {option} {file}: is an existing file, not a folder (choose a folder path)"
NOT_A_FILE = "error: {option} {dir}: is an existing folder, expected a file path"
CASES = {
    **{case: (args, NOT_A_FOLDER.replace("{option}", option)) for case, (args, option) in FOLDER_OPTIONS.items()},
    **{case: (args, NOT_A_FILE.replace("{option}", option)) for case, (args, option) in FILE_OPTIONS.items()},
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_an_output_path_of_the_wrong_kind_is_one_line(
    case: str, paths: dict[str, Path], cli_fails: Callable[..., str], monkeypatch: pytest.MonkeyPatch
) -> None:
    template, message = CASES[case]
    monkeypatch.chdir(paths["dir"].parent)
    err = cli_fails(*_args(template, paths))
    assert err == _args([message], paths)[0]
    assert paths["file"].read_text(encoding="utf-8") == "mine\n"
    assert sorted(p.name for p in paths["dir"].iterdir()) == ["x.txt"]


def test_an_export_robot_folder_that_is_a_file_is_one_line(
    tmp_path: Path, cli_fails: Callable[..., str], monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "export"
    out.mkdir()
    (out / "a").write_text("mine\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    err = cli_fails("export", "smoke", "-f", "tum", "--out", out)
    assert err == f"error: --out {out}: {out / 'a'} is an existing file, not a robot folder"
    assert (out / "a").read_text(encoding="utf-8") == "mine\n"
