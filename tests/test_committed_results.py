"""The tests' list of committed result folders is the one ``.gitignore`` keeps, and a user's runs stay out."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from committed_results import COMMITTED_ROOTS, RESULTS, ROOT, committed_files


def unignored_result_folders(gitignore: str) -> list[str]:
    """The folders under ``results/`` a ``.gitignore`` keeps: un-ignored, and their contents not ignored again."""
    lines = [ln.strip() for ln in gitignore.splitlines()]
    kept = [ln[1:].rstrip("/") for ln in lines if ln.startswith("!results/") and ln.endswith("/")]
    ignored_again = {ln[: -len("/*")] for ln in lines if ln.startswith("results/") and ln.endswith("/*")}
    return [folder for folder in kept if folder not in ignored_again]


def test_the_parse_by_hand() -> None:
    text = "results/*\n!results/a/\n!results/b/\nresults/b/*\n!results/b/c/\n!results/README.md\n"
    assert unignored_result_folders(text) == ["results/a", "results/b/c"]


def test_the_committed_roots_are_the_folders_gitignore_keeps() -> None:
    gitignore = (ROOT / ".gitignore").read_text(encoding="utf-8")
    assert "results/*" in gitignore.splitlines()  # everything else under results/ is a user's
    assert sorted(unignored_result_folders(gitignore)) == sorted(
        p.relative_to(ROOT).as_posix() for p in COMMITTED_ROOTS
    )


@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(), reason="not a git checkout")
def test_git_keeps_the_roots_and_ignores_a_users_run() -> None:
    """Every file git tracks under results/ lies in a committed root; a demo run's folder is ignored."""

    def git(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)

    tracked = git("ls-files", "results").stdout.split()
    assert tracked
    outside = [t for t in tracked if not any((ROOT / t).is_relative_to(r) for r in COMMITTED_ROOTS)]
    assert outside == [], outside
    demo = "results/demo/seed1-0123abcd/metrics.json"
    work = "results/benchmark/standard/work/low-s0/metrics.json"
    assert git("check-ignore", "-q", "--no-index", demo).returncode == 0
    assert git("check-ignore", "-q", "--no-index", work).returncode == 0
    assert git("check-ignore", "-q", "--no-index", "results/reference/demo/metrics.json").returncode == 1


def test_committed_files_leave_out_a_users_runs(tmp_path: Path) -> None:
    """A demo run beside the roots and a benchmark's ignored work folder are not listed."""
    roots = [tmp_path / "results" / "reference", tmp_path / "results" / "benchmark" / "standard"]
    for rel in (
        "reference/demo/metrics.json",
        "reference/summary.json",
        "benchmark/standard/cells/low/cell.json",
        "benchmark/standard/work/low-s0/metrics.json",  # the benchmark's own run folders
        "demo/seed1-0123abcd/metrics.json",  # roman-sim demo
        "smoke/seed0-0123abcd/metrics.json",  # roman_sim.testing.run_scenario
    ):
        (tmp_path / "results" / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "results" / rel).write_text("{}")
    (roots[1] / ".gitignore").write_text("work/\n")
    got = [p.relative_to(tmp_path / "results").as_posix() for p in committed_files("*.json", roots)]
    assert got == ["benchmark/standard/cells/low/cell.json", "reference/demo/metrics.json", "reference/summary.json"]


def test_the_committed_files_are_found() -> None:
    """The real roots hold the committed files (the tests that read them would pass over nothing)."""
    files = committed_files("*.json")
    assert all(p.is_relative_to(RESULTS) for p in files)
    assert {next(r for r in COMMITTED_ROOTS if p.is_relative_to(r)) for p in files} == set(COMMITTED_ROOTS)
