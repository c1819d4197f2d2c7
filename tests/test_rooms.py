"""The rooms guard (``tools/check_rooms.py``, run by CI): the tree keeps its rooms, and a misplaced module,
a package over its budget or a test out of place fails with one line naming where it belongs.

The failures are made in a copy of the package (and of the rooms file) in a temporary folder.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "check_rooms.py"


def _check(root: Path = ROOT) -> tuple[int, list[str]]:
    """Exit code and output lines of the guard on the repository at ``root``."""
    res = subprocess.run(
        [sys.executable, str(TOOL), "--root", str(root)], capture_output=True, text=True, timeout=120, check=False
    )
    assert res.stderr == "", res.stderr
    return res.returncode, res.stdout.splitlines()


def _copy(tmp_path: Path) -> Path:
    """The package and the rooms file in ``tmp_path/repo``, with an empty test tree."""
    repo = tmp_path / "repo"
    shutil.copytree(ROOT / "roman_sim", repo / "roman_sim", ignore=shutil.ignore_patterns("__pycache__"))
    (repo / "tools").mkdir()
    shutil.copy(ROOT / "tools" / "rooms.toml", repo / "tools" / "rooms.toml")
    (repo / "tests").mkdir()
    return repo


def test_the_tree_keeps_its_rooms() -> None:
    import tomllib

    rooms = len(tomllib.loads((ROOT / "tools" / "rooms.toml").read_text(encoding="utf-8"))["packages"])
    code, lines = _check()
    tail = "within their budgets, every module in a subject of its package; tests/ mirrors roman_sim/"
    assert (code, lines) == (0, [f"rooms: {rooms} rooms {tail}"])


def test_the_copy_keeps_its_rooms_too(tmp_path: Path) -> None:
    assert _check(_copy(tmp_path))[0] == 0  # so each failure below is the one change made


@pytest.mark.parametrize(
    ("make", "path"),
    [
        ("moved", "roman_sim/evaluation/ranking.py"),  # a module of the benchmark's, moved into evaluation
        ("new", "roman_sim/report/board_heatmap.py"),  # a new module of the leaderboard's family, in report
    ],
)
def test_a_module_out_of_its_package_names_the_package_it_belongs_in(tmp_path: Path, make: str, path: str) -> None:
    repo = _copy(tmp_path)
    if make == "moved":
        (repo / "roman_sim/benchmark/ranking.py").rename(repo / path)
    else:
        (repo / path).write_text('"""A leaderboard figure, drawn in the wrong room."""\n')
    package = path.split("/")[1]
    assert _check(repo) == (
        1,
        [f"{path}: not a subject of roman_sim.{package}; it belongs in roman_sim.benchmark (leaderboard)"],
    )


def test_a_module_of_no_subject_is_named(tmp_path: Path) -> None:
    repo = _copy(tmp_path)
    (repo / "roman_sim/pipeline/helpers.py").write_text('"""Odds and ends."""\n')
    code, lines = _check(repo)
    assert code == 1 and len(lines) == 1
    assert lines[0].startswith("roman_sim/pipeline/helpers.py: in no subject of roman_sim.pipeline (tools/rooms.toml)")


def test_a_package_over_its_budget_is_named_with_its_lines(tmp_path: Path) -> None:
    repo = _copy(tmp_path)
    lines = sum(len(p.read_text(encoding="utf-8").splitlines()) for p in (repo / "roman_sim/posegraph").rglob("*.py"))
    rooms = repo / "tools/rooms.toml"
    text = rooms.read_text(encoding="utf-8")
    assert "[packages.posegraph]\nbudget = 1100\n" in text
    rooms.write_text(
        text.replace("[packages.posegraph]\nbudget = 1100\n", f"[packages.posegraph]\nbudget = {lines - 1}\n")
    )
    code, out = _check(repo)
    assert code == 1 and len(out) == 1
    assert out[0].startswith(f"roman_sim.posegraph: {lines} lines, over its budget of {lines - 1} (tools/rooms.toml)")


def test_a_package_without_a_room_and_a_room_without_a_package(tmp_path: Path) -> None:
    repo = _copy(tmp_path)
    (repo / "roman_sim/extras").mkdir()
    (repo / "roman_sim/extras/__init__.py").write_text("")
    shutil.rmtree(repo / "roman_sim/viz")
    assert _check(repo) == (
        1,
        [
            "roman_sim/extras: has no room in tools/rooms.toml (add its budget and subjects)",
            "tools/rooms.toml: roman_sim.viz does not exist",
        ],
    )


def test_an_entry_that_names_no_module_is_stale(tmp_path: Path) -> None:
    repo = _copy(tmp_path)
    (repo / "roman_sim/studies/claims.py").unlink()
    assert _check(repo) == (
        1,
        ["tools/rooms.toml: roman_sim.studies (claims) lists 'claims', which names no module of it"],
    )


def test_a_malformed_rooms_file_is_one_line(tmp_path: Path) -> None:
    repo = _copy(tmp_path)
    rooms = repo / "tools/rooms.toml"
    rooms.write_text(rooms.read_text(encoding="utf-8").replace("budget = 1100", 'budget = "many"'))
    assert _check(repo) == (
        1,
        ["error: " + str(rooms) + ": packages.posegraph.budget: a positive number of lines is required"],
    )


def test_tests_out_of_place_are_named(tmp_path: Path) -> None:
    repo = _copy(tmp_path)
    tests = repo / "tests"
    for folder in ("evaluation", "report", "robustness"):
        (tests / folder).mkdir()
    (tests / "evaluation/test_posegraph.py").write_text("from roman_sim.posegraph import LoopClosure\n")
    (tests / "evaluation/test_pairs.py").write_text("from roman_sim.evaluation.pairs import PairTruth\n")
    (tests / "report/test_docs.py").write_text("import json\n")
    (tests / "robustness/test_limits.py").write_text("from roman_sim.cli import app\n")
    assert _check(repo) == (
        1,
        [
            "tests/robustness/: roman_sim/robustness/ is no package (tests/<package>/ mirrors roman_sim/<package>/; "
            "tests of the repository itself sit in tests/)",
            "tests/evaluation/test_posegraph.py: imports nothing of roman_sim.evaluation and names it nowhere: it "
            "belongs in the folder of its subject",
            "tests/evaluation/test_posegraph.py: named after roman_sim.posegraph, which it imports: it belongs in "
            "tests/posegraph/",
            "tests/report/test_docs.py: imports nothing of roman_sim.report and names it nowhere: it belongs in the "
            "folder of its subject",
            "tests/robustness/test_limits.py: imports nothing of roman_sim.robustness and names it nowhere: it "
            "belongs in the folder of its subject",
        ],
    )
