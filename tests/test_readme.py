"""The README: short, its two commands where CI reads them, its excerpt and figure from committed data."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
from committed_results import REFERENCE as REF
from readme_commands import FIRST, TEST, bash_commands, marked_command, markers

from roman_sim.core.records import from_json
from roman_sim.evaluation.run_summary import RunSummary
from roman_sim.studies import pages
from roman_sim.studies.reference import DEMO, FIGURE_PNG, ReferenceRecord, demo_summary, read_reference
from roman_sim.studies.verify import verify_run

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
CI = ROOT / ".ci" / "run"


def _text() -> str:
    return README.read_text(encoding="utf-8")


def _run(methods: dict, ate: dict | None = None) -> RunSummary:
    """A hand-made run summary: its methods' cross-robot sets (same-robot sets empty) and ATE rows."""
    empty = {"max_recall": None, "max_hits": 0, "n_relevant": 0, "recall_ci": None, "few": True}
    sets = {m: {"inter": {**empty, **e["inter"]}, "intra": empty} for m, e in methods.items()}
    data = {"headline": "inter", "pairs": {}, "n_skipped": 0, "methods": sets, "ate": ate or {}}
    return from_json(RunSummary, data, "run")


def test_readme_is_short():
    assert len(_text().splitlines()) <= 200


def test_readme_starts_with_the_demo_and_the_test_command():
    text = _text()
    first_two = bash_commands(text[: text.index("## ")])
    assert first_two == [
        "pip install -e . && roman-sim demo",
        'pip install -e ".[test]" -c constraints.txt && pip install --no-deps robotdatapy==1.1.17 && '
        "python -m pytest -q -n auto --dist loadfile --timeout=900 --timeout-method=signal",
    ]
    # each is the one command between its markers, the order CI runs them in
    assert [marked_command(FIRST, text), marked_command(TEST, text)] == first_two
    assert text.index(markers(FIRST)[1]) < text.index(markers(TEST)[0])
    # the docs site's front page starts with the same two
    assert bash_commands((ROOT / "docs" / "index.md").read_text(encoding="utf-8"))[:2] == first_two


def _ci_extract(name: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``.ci/run``'s own ``readme_command`` function, run on the README in ``cwd``."""
    ci = CI.read_text(encoding="utf-8")
    func = ci[ci.index("readme_command() {") : ci.index("\n}\n", ci.index("readme_command() {")) + 3]
    script = f"set -euo pipefail\n{func}readme_command {name}\n"
    return subprocess.run(["bash", "-c", script], cwd=cwd, capture_output=True, text=True)


def test_ci_runs_the_readme_commands_in_order():
    """CI reads both commands with one function and runs the first, then the second, nothing between but checks."""
    ci = CI.read_text(encoding="utf-8")
    assert "first_cmd=$(readme_command first-command)" in ci and "test_cmd=$(readme_command test-command)" in ci
    order = [ci.index(f'eval "${var}"') for var in ("first_cmd", "test_cmd")]
    assert order[0] < ci.index("-c constraints.txt") < order[1]  # the open install runs before the locked one
    assert "--no-deps" not in ci  # every install of the tests is the README's own


@pytest.mark.parametrize("name", [FIRST, TEST])
def test_ci_reads_each_command_between_its_markers(name: str, tmp_path: Path):
    """The extraction of ``.ci/run``, run on the README, gives exactly the README's command."""
    out = _ci_extract(name, ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout == marked_command(name)
    # a README without the markers gives nothing, and .ci/run stops with one line
    (tmp_path / "README.md").write_text("```bash\npip install -e . && roman-sim demo\npython -m pytest\n```\n")
    out = _ci_extract(name, tmp_path)
    assert out.returncode == 1 and out.stdout == ""
    begin, end = markers(name)
    assert out.stderr == f"error: README.md needs exactly one command between {begin} and {end}\n"


def test_readme_links_resolve():
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", _text()):
        if not target.startswith("http"):
            assert (ROOT / target).exists(), target


@pytest.mark.skipif(not (REF / DEMO / "pairs.csv.gz").is_file(), reason="no committed demo run")
def test_demo_excerpt_follows_from_the_demo_run():
    res = verify_run(REF / DEMO, rel_tol=1e-6, pairs_file="pairs.csv.gz", tum_suffix=".gz")
    assert res.ok, res.differences[:10]
    assert pages.current_block(_text(), pages.DEMO_MARKERS) == pages.demo_block(demo_summary(REF))


@pytest.mark.skipif(not (REF / "summary.json").is_file(), reason="no committed reference results")
def test_figure_shows_the_committed_summary():
    """The PNG carries the numbers it was drawn from; they are the summary's (re-derived elsewhere)."""
    summary = read_reference(REF / "summary.json")
    assert f"]({FIGURE_PNG.as_posix()})" in _text()
    assert pages.read_figure_data(ROOT / FIGURE_PNG) == pages.figure_data(summary)


def test_figure_data_by_hand(tmp_path):
    """Bins in heading order, ROMAN first, every count and interval carried over."""

    def rec(h: int, n: int) -> dict:
        return {"max_recall": h / n, "max_hits": h, "n_relevant": n, "recall_ci": [0.1, 0.9], "few": n < 5}

    method = {"inter": {"bins": {"120-180": rec(3, 6), "0-60": rec(1, 5)}}}
    summary = ReferenceRecord({"heading_sweep": _run({"clipper": method, "roman": method})}, [])
    data = pages.figure_data(summary)
    assert list(data.methods) == ["roman", "clipper"]
    assert data.methods["roman"] == [
        pages.BinPoint(bin="0-60", recall=0.2, hits=1, relevant=5, ci=(0.1, 0.9)),
        pages.BinPoint(bin="120-180", recall=0.5, hits=3, relevant=6, ci=(0.1, 0.9)),
    ]
    png = pages.write_figure(summary, tmp_path / "f.png")
    assert pages.read_figure_data(png) == data


def test_demo_block_by_hand():
    """One row per method and heading with relevant pairs, one column per operating point, the ATE line."""

    def pt(k, hits, n, fp, reached=True):
        pos = hits + fp
        return {
            "k": k,
            "reached": reached,
            "hits": hits,
            "n_relevant": n,
            "false_positives": fp,
            "recall": hits / n,
            "recall_ci": [0.1, 0.9],
            "precision": hits / pos if pos else None,
            "precision_ci": [0.2, 0.8] if pos else None,
        }

    def rec(h, n):
        points = {
            "max_recall": pt(0, h, n, 3 * h),  # P 0.25
            "precision_90": pt(5, h // 2, n, 0),
            "precision_100": pt(None, 0, n, 0, reached=False),
            "acceptance": pt(4, h - 1, n, 1),
        }
        return {
            "max_recall": h / n,
            "max_hits": h,
            "n_relevant": n,
            "recall_ci": [0.1, 0.9],
            "few": n < 5,
            "points": points,
        }

    empty = {"max_recall": None, "max_hits": 0, "n_relevant": 0, "recall_ci": None, "few": True, "points": {}}
    inter = {**rec(8, 10), "bins": {"120-180": rec(6, 8), "0-60": empty, "60-120": rec(2, 2)}}
    ate = {
        "roman": {"connected": 2, "common": 0.5, "all": 0.25},
        "oracle": {"connected": 2, "common": 0.1, "all": None},
    }
    run = _run({"clipper": {"inter": inter}, "roman": {"inter": inter}}, ate)
    lines = pages.demo_block(run).splitlines()
    assert lines[0] == pages.DEMO_MARKERS[0] and lines[-1] == pages.DEMO_MARKERS[1]
    assert lines[1:3] == [
        "| method | cross-robot pairs | max recall | recall at P>=0.9 | recall at P=1 | recall at acceptance |",
        "|---|---|---|---|---|---|",
    ]
    assert lines[3:6] == [
        "| roman | all | 0.80 (8/10) [0.10, 0.90] P 0.25 k 0 | 0.40 (4/10) [0.10, 0.90] P 1.00 k 5 | "
        "not reached (0/10) | 0.70 (7/10) [0.10, 0.90] P 0.88 k 4 |",
        "| roman | 60-120 deg | n<5: 2/2 P 0.25 k 0 | n<5: 1/2 P 1.00 k 5 | not reached (0/2) | n<5: 1/2 P 0.50 k 4 |",
        "| roman | 120-180 deg | 0.75 (6/8) [0.10, 0.90] P 0.25 k 0 | 0.38 (3/8) [0.10, 0.90] P 1.00 k 5 | "
        "not reached (0/8) | 0.62 (5/8) [0.10, 0.90] P 0.83 k 4 |",
    ]
    assert [ln.split(" | ")[:2] for ln in lines[6:9]] == [
        ["| clipper", h] for h in ("all", "60-120 deg", "120-180 deg")
    ]
    assert lines[-2] == "ATE RMSE over both robots (m, SE(3) aligned): roman 0.25."
