"""``roman-sim score`` names a closure file's wrong convention, and the flag that applies it recovers the figures.

A run's own ROMAN closures are written three wrong ways (quaternions w first, edges
inverted, robots swapped): each scores far fewer hits, ``score`` says so in one line naming
the flag, and that flag gives back the run's own figures, every operating point. A flag
that makes a right file worse is an error, before anything is written.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import re
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from roman_sim.core.geometry import inv_T
from roman_sim.interop.closures import Closure, write_csv_closures
from roman_sim.pipeline.result import RunResult
from roman_sim.scoring.closure_conventions import Convention
from roman_sim.scoring.external import ExternalScore, run_closures, score_external

PAGE = Path(__file__).resolve().parents[2] / "docs" / "interop.md"
FLAGS = {
    "w_first": ["--quaternion-order", "wxyz"],
    "inverted": ["--invert-edges"],
    "swapped": ["--swap-robots"],
}
CONVENTION = {
    "w_first": Convention(quaternion_order="wxyz"),
    "inverted": Convention(invert_edges=True),
    "swapped": Convention(swap_robots=True),
}


def _w_first(path: Path) -> None:
    """Rewrite a closure CSV with each quaternion's four numbers in the order w x y z."""
    rows = list(csv.reader(io.StringIO(path.read_text(encoding="utf-8"))))
    for row in rows[1:]:
        row[7:11] = [row[10], *row[7:10]]
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    path.write_text(buf.getvalue(), encoding="utf-8")


@pytest.fixture(scope="module")
def files(smoke_run: RunResult, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The run's ROMAN closures written right and three wrong ways."""
    d = tmp_path_factory.mktemp("conventions")
    closures = run_closures(smoke_run.run_dir, "roman")
    other = {"a": "b", "b": "a"}
    wrong: dict[str, list[Closure]] = {
        "right": closures,
        "w_first": closures,
        "inverted": [dataclasses.replace(c, T_pa_pb=inv_T(c.T_pa_pb)) for c in closures],
        "swapped": [dataclasses.replace(c, robot_a=other[c.robot_a], robot_b=other[c.robot_b]) for c in closures],
    }
    for name, rows in wrong.items():
        write_csv_closures(d / f"{name}.csv", rows)
    _w_first(d / "w_first.csv")
    return {name: d / f"{name}.csv" for name in wrong}


def _points(run: RunResult, method: str) -> list[object]:
    m = run.metrics.methods[method]
    return [(m.set(k).overall.operating_points, m.set(k).pr_curve.tp.tolist()) for k in ("inter", "intra")]


@pytest.fixture(scope="module")
def as_read(
    smoke_run: RunResult, files: dict[str, Path], tmp_path_factory: pytest.TempPathFactory
) -> dict[str, ExternalScore]:
    """Each file scored as read (no flag)."""
    d = tmp_path_factory.mktemp("as_read")
    return {name: score_external(smoke_run.run_dir, path, d / name) for name, path in files.items()}


def _acceptance_hits(res: ExternalScore) -> int:
    point = res.run.metrics.methods["external"].set("inter").overall.operating_points["acceptance"]
    assert point is not None
    return point.hits


def test_the_right_file_scores_best_as_read(as_read: dict[str, ExternalScore]) -> None:
    res = as_read["right"]
    assert res.warning is None and res.conventions is not None
    assert res.conventions.best() == Convention()


@pytest.mark.parametrize("case", sorted(FLAGS))
def test_a_wrong_convention_is_named_and_its_flag_recovers_the_figures(
    smoke_run: RunResult, files: dict[str, Path], as_read: dict[str, ExternalScore], tmp_path: Path, case: str
) -> None:
    res, right = as_read[case], as_read["right"].run
    check = res.conventions
    assert check is not None and check.best() == CONVENTION[case]
    flag = " ".join(FLAGS[case])
    assert res.warning is not None and res.warning.startswith(
        f"{files[case]} scores far better under another convention: {check.correct[CONVENTION[case]]} of "
    )
    assert res.warning.endswith(f"; scored as read, rerun with {flag} to apply it")
    assert check.correct[CONVENTION[case]] >= 2 * check.correct[Convention()] + 3  # far better, by the rule
    # as read, the acceptance point loses most of its hits (the file is silently wrong without the check)
    assert _acceptance_hits(res) <= _acceptance_hits(as_read["right"]) // 2
    report = (res.run.run_dir / "report.md").read_text(encoding="utf-8")
    assert f"**Warning:** {res.warning}" in report
    # the flag applies it: every operating point and every hit count of the right file, exactly
    kw = {"w_first": {"quaternion_order": "wxyz"}, "inverted": {"invert_edges": True}, "swapped": {"swap_robots": True}}
    fixed = score_external(smoke_run.run_dir, files[case], tmp_path / "fixed", **kw[case])  # type: ignore[arg-type]
    assert fixed.warning is None
    assert _points(fixed.run, "external") == _points(right, "external")
    assert fixed.conventions is not None and fixed.conventions.correct[CONVENTION[case]] == max(
        fixed.conventions.correct.values()
    )


def test_the_pages_figures(as_read: dict[str, ExternalScore]) -> None:
    """docs/interop.md's figures of the four files, as measured (integer counts within 1)."""
    text = " ".join(PAGE.read_text(encoding="utf-8").split())
    m = re.search(
        r"ROMAN closures give (\d+) of (\d+) estimated pairs correct and (\d+) of (\d+) hits at the acceptance "
        r"threshold; written w first they give (\d+) correct pairs and (\d+) hits, inverted (\d+) and (\d+), swapped "
        r"(\d+) and (\d+)\.",
        text,
    )
    assert m is not None
    page = [int(v) for v in m.groups()]
    right = as_read["right"]
    assert right.conventions is not None
    n_relevant = right.run.metrics.methods["external"].set("inter").overall.n_relevant
    got = [right.conventions.correct[Convention()], right.conventions.estimated[Convention()]]
    got += [_acceptance_hits(right), n_relevant]
    for case in ("w_first", "inverted", "swapped"):
        check = as_read[case].conventions
        assert check is not None
        got += [check.correct[Convention()], _acceptance_hits(as_read[case])]
    assert page[1] == got[1] and page[3] == got[3], (page, got)
    assert all(abs(a - b) <= 1 for a, b in zip(page, got)), (page, got)


def test_the_warning_is_one_line_of_the_command(smoke_run: RunResult, files: dict[str, Path], tmp_path: Path) -> None:
    from roman_sim.cli import app

    result = CliRunner().invoke(
        app, ["score", str(smoke_run.run_dir), "-c", str(files["inverted"]), "-o", str(tmp_path / "o")]
    )
    assert result.exit_code == 0, result.output
    warnings = [ln for ln in result.output.splitlines() if ln.startswith("warning: ")]
    assert len(warnings) == 1 and warnings[0].endswith("rerun with --invert-edges to apply it")
    assert "its edges look inverted, T_b_a for T_a_b" in warnings[0]


@pytest.mark.parametrize("case", sorted(FLAGS))
def test_a_flag_that_makes_things_worse_is_an_error(
    smoke_run: RunResult, files: dict[str, Path], tmp_path: Path, cli_fails: Callable[..., str], case: str
) -> None:
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "-c", files["right"], *FLAGS[case], "-o", out)
    flag = " ".join(FLAGS[case])
    assert err.startswith(f"error: {flag} makes {files['right']} score worse: "), err
    assert err.endswith(f"estimated pairs correct as read (drop {flag})"), err
    assert not out.exists()


def test_convention_flags_checked(
    smoke_run: RunResult, files: dict[str, Path], tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "-c", files["right"], "--quaternion-order", "wxzy", "-o", out)
    assert err == "error: --quaternion-order wxzy: allowed: xyzw, wxyz"
    assert not out.exists()
