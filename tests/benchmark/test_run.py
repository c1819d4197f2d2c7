"""``roman-sim benchmark`` end to end on a tiny suite: cells, a plug-in failing in one cell, resumption,
the leaderboard against its raw pairs, the regression helper, and bad input in one line each."""

from __future__ import annotations

import csv
import gzip
import io
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from roman_sim.align.aligners import RomanAligner, RomanParams
from roman_sim.benchmark.board import leaderboard
from roman_sim.benchmark.board_markdown import README_BEGIN, README_END, readme_block
from roman_sim.benchmark.board_records import read_leaderboard
from roman_sim.benchmark.cells import Cell
from roman_sim.benchmark.run import BenchmarkJob
from roman_sim.benchmark.suites import load_suite
from roman_sim.cli import app
from roman_sim.core.errors import ConfigError
from roman_sim.testing import assert_benchmark, benchmark_pins

pytestmark = pytest.mark.slow

SUITE = """\
name: tiny
description: two tiny crossing scenes
scene: {robots: 3, length_m: 24.0, site_radius_m: 2.0, extent_m: 40.0, render_rgb: false,
        image_width: 160, image_height: 120}
levels: {distinct: 0.0, repetitive: 1.0}
seeds: [0]
methods: [roman]
"""

#: An aligner that works on distinct places and raises on repetitive ones, where every object is the
#: same bush (at ambiguity 1 every descriptor belongs to one family: their mean cosine is high).
PLUGIN = """
import numpy as np
from roman_sim.align import build_aligner


class FailsOnRepetitivePlaces:
    name = "FailsOnRepetitivePlaces"

    def __init__(self):
        self.inner = build_aligner("roman", {})

    def align(self, a, b):
        d = np.asarray(a.descriptors, dtype=float)
        if len(d) >= 4:
            c = d @ d.T
            mean = (c.sum() - np.trace(c)) / (len(d) * (len(d) - 1))
            if mean > 0.8:
                raise RuntimeError(f"repetitive place (mean descriptor cosine {mean:.2f})")
        out = self.inner.align(a, b)
        out.method = self.name
        return out
"""


@pytest.fixture(scope="module")
def home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("bench")
    (d / "tiny.yaml").write_text(SUITE)
    (d / "bench_plugins.py").write_text(PLUGIN)
    return d


@pytest.fixture(scope="module")
def failed_once(home: Path) -> dict:
    """The tiny suite with roman and the plug-in, through the CLI: one cell fails, the other runs."""
    mp = pytest.MonkeyPatch()
    mp.chdir(home)
    mp.syspath_prepend(str(home))
    try:
        res = CliRunner().invoke(
            app,
            [
                "benchmark",
                "tiny.yaml",
                "--methods",
                "roman,bench_plugins:FailsOnRepetitivePlaces",
                "--out",
                "out",
                "--executor",
                "serial",
            ],
        )
    finally:
        mp.undo()
    return {"code": res.exit_code, "out": res.output, "folder": home / "out"}


def test_a_plugin_failing_in_one_cell_fails_that_cell_only(failed_once: dict) -> None:
    assert failed_once["code"] == 1, failed_once["out"]
    assert "repetitive-s0" in failed_once["out"] and "repetitive place (mean descriptor cosine" in failed_once["out"]
    folder = failed_once["folder"]
    rec = json.loads((folder / "benchmark.json").read_text())
    assert {c["id"]: c["status"] for c in rec["cells"]} == {"distinct-s0": "ok", "repetitive-s0": "failed"}
    board = read_leaderboard(folder / "leaderboard.json")
    assert list(board.failed_cells) == ["repetitive-s0"] and not board.bound_met
    distinct = board.levels[0]
    assert (
        distinct.name == "distinct"
        and distinct.overall is not None
        and set(distinct.overall.methods)
        == {
            "roman",
            "FailsOnRepetitivePlaces",
        }
    )
    assert "## Cells that did not finish" in (folder / "leaderboard.md").read_text()
    # one seed per level: no held-out figures, one statement instead
    assert distinct.deployable is not None and str(distinct.deployable.note).startswith(
        "held-out figures need at least two worlds"
    )
    assert "No held-out figures: held-out figures need" in (folder / "leaderboard.md").read_text()
    assert (folder / ".gitignore").read_text() == "work/\n"


def _own_max_hits(path: Path) -> dict[str, tuple[int, int]]:
    """Max-recall hits and relevant cross-robot pairs per method, from a raw pairs table by hand."""
    rows = [r for r in csv.DictReader(io.StringIO(gzip.decompress(path.read_bytes()).decode())) if r["kind"] == "inter"]
    out = {}
    for m in sorted({r["method"] for r in rows}):
        mine = [r for r in rows if r["method"] == m]
        rel = [float(r["center_dist_m"]) <= 10.0 for r in mine]
        ok = [r["correct"] == "true" for r in mine]
        n = [int(r["n_assoc"]) for r in mine]
        best = max(sum(1 for i in range(len(mine)) if n[i] >= k and rel[i] and ok[i]) for k in range(31))
        out[m] = (best, sum(rel))
    return out


def test_planned_relevant_pairs_are_the_run_s_and_the_board_follows_from_raw_pairs(failed_once: dict, by_hand) -> None:
    folder = failed_once["folder"]
    plan = json.loads((folder / "plan.json").read_text())["cells"]["distinct-s0"]
    board, _ = leaderboard(folder)
    level = board.levels[0]
    assert level.overall is not None
    assert [b.n_relevant for b in level.bins] == plan["relevant"]  # planned before rendering = scored
    own = _own_max_hits(folder / "cells" / "distinct-s0" / "pairs.csv.gz")
    for m, (hits, rel) in own.items():
        p = level.overall.point(m, "max_recall")
        assert p is not None and (p.hits, p.n_relevant) == (hits, rel), m
    assert read_leaderboard(folder / "leaderboard.json") == board
    block = readme_block(board, "plots/recall_heading.png")
    assert block.startswith(README_BEGIN) and block.endswith(README_END)
    p = level.overall.point("roman", "max_recall")
    assert "- max recall: roman ranks first alone in " in block and "distinct (index 0." in block
    assert p is not None and p.hits <= p.n_relevant
    hand = by_hand(folder)  # the scorer the committed standard results are checked with
    for b in level.bins:
        for m in b.methods:
            q = b.point(m, "max_recall")
            assert q is not None and hand.get(("distinct", b.heading, m), (0, 0)) == (q.hits, q.n_relevant), (
                b.heading,
                m,
            )


class _FourAssociations(RomanParams):
    """ROMAN's parameters with another default (as if its code had been edited)."""

    min_associations_for_transform: int = 4


def test_a_finished_cell_runs_again_when_a_default_or_the_code_changes(
    failed_once: dict, home: Path, monkeypatch
) -> None:
    monkeypatch.syspath_prepend(str(home))
    monkeypatch.chdir(home)
    suite = load_suite(home / "tiny.yaml")
    job = BenchmarkJob(suite, failed_once["folder"], ["roman", "bench_plugins:FailsOnRepetitivePlaces"])
    cell = Cell("distinct", 0, job.scenes["distinct"])
    assert job.finished(cell)  # nothing changed: reused
    with monkeypatch.context() as m:
        m.setattr(RomanAligner, "params_model", _FourAssociations)
        assert not job.finished(cell)  # a changed default of a method the cell runs
    assert job.finished(cell)
    plugin = home / "bench_plugins.py"
    source = plugin.read_text()
    try:
        plugin.write_text(source + "\n# edited\n")
        assert not job.finished(cell)  # the code of a plug-in the cell runs
    finally:
        plugin.write_text(source)
    assert job.finished(cell)


def test_a_rerun_resumes_and_assert_benchmark_pins_cells(failed_once: dict, home: Path, monkeypatch) -> None:
    folder = failed_once["folder"]
    suite = load_suite(home / "tiny.yaml")
    job = BenchmarkJob(suite, folder, ["roman", "bench_plugins:FailsOnRepetitivePlaces"])
    monkeypatch.syspath_prepend(str(home))
    monkeypatch.chdir(home)
    out = job.run()
    assert out.reused == ["distinct-s0"] and list(out.failures) == ["repetitive-s0"]
    board = read_leaderboard(folder / "leaderboard.json")
    pins = {k: v for k, v in benchmark_pins(board, "roman").items() if k.startswith("distinct/")}
    again = folder  # roman alone: the cells' evaluation runs again, their maps are reused
    board2 = assert_benchmark("roman", home / "tiny.yaml", pinned=pins, out=again)  # same cells, same counts
    assert benchmark_pins(board2, "roman")["distinct/all"] == pins["distinct/all"]
    hits, rel = pins["distinct/all"]
    with pytest.raises(AssertionError, match="relevant pairs changed"):
        assert_benchmark("roman", home / "tiny.yaml", pinned={"distinct/all": (hits, rel + 1)}, out=again)
    with pytest.raises(AssertionError, match=r"roman max_recall distinct/all: \d+/\d+ hits, pinned"):
        assert_benchmark("roman", home / "tiny.yaml", pinned={"distinct/all": ((hits + 2) % (rel + 1), rel)}, out=again)


def test_bad_input_fails_in_one_line(home: Path, failed_once: dict, tmp_path: Path) -> None:
    r = CliRunner()

    def err(*args: str) -> str:
        res = r.invoke(app, ["benchmark", *args])
        assert res.exit_code == 1, res.output
        lines = [x for x in res.output.splitlines() if x.strip()]
        assert len(lines) == 1, res.output
        return lines[0]

    assert err("huge").startswith("error: unknown benchmark suite 'huge' (valid: envelope, quick, standard")
    assert err("quick", "--methods", "romann").startswith("error: --methods: unknown method 'romann'")
    assert "holds the 'tiny' benchmark, not 'quick'" in err("quick", "--out", str(failed_once["folder"]))
    with pytest.raises(ConfigError, match="with overrides"):
        BenchmarkJob(load_suite(home / "tiny.yaml"), failed_once["folder"], ["roman"], ["seed=3"]).guard()
    run_dir = tmp_path / "a_run"
    run_dir.mkdir()
    (run_dir / "manifest.json").write_text("{}")
    assert "holds a run or a sweep, not a benchmark" in err("quick", "--out", str(run_dir))
