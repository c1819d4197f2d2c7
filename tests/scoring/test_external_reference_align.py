"""The reference ROMAN's per-pair output (``align/<r_i>_<r_j>/align.g2o``), written from a run, read back as a curve.

The testbed writes a run's own ROMAN results in the reference's per-pair layout
(``write_reference_align``, from the run's ``alignments.json``); ``roman-sim score`` reads the
folder (times from each ``align.json``, or by pose index from the dense timestamps file) and
its ``# LC:`` counts give the run's own ROMAN curve: the same hits at every threshold.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from roman_sim.interop.base import EXPORT_EPOCH_NS
from roman_sim.interop.closures import Closure
from roman_sim.interop.roman_align import read_align
from roman_sim.pipeline.result import RunResult
from roman_sim.scoring.external import read_external, run_closures, score_external, write_reference_align


@pytest.fixture(scope="module")
def closures(smoke_run: RunResult) -> list[Closure]:
    return run_closures(smoke_run.run_dir, "roman")


@pytest.fixture(scope="module")
def written(smoke_run: RunResult, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("reference") / "demo_out"
    write_reference_align(smoke_run.run_dir, out)
    return out


def test_the_layout_is_the_references(smoke_run: RunResult, closures: list[Closure], written: Path) -> None:
    """Keys a<frame index> b<frame index>, a '# LC: n' line before each edge, align.json in the same order."""
    assert sorted(p.name for p in (written / "align").iterdir()) == ["a_a", "a_b", "b_b"]
    from roman_sim.pipeline.stages.maps import MapsStage
    from roman_sim.scoring.external import _load_stage

    maps = _load_stage(smoke_run.run_dir, smoke_run.scenario, MapsStage()).maps
    frames = {r: m.odometry.t for r, m in maps.items()}
    lines = (written / "align" / "a_b" / "align.g2o").read_text(encoding="utf-8").splitlines()
    entries = json.loads((written / "align" / "a_b" / "align.json").read_text(encoding="utf-8"))
    inter = sorted((c for c in closures if c.robot_a != c.robot_b), key=lambda c: (c.t_a, c.t_b))
    assert len(lines) == 2 * len(inter) == 2 * len(entries) and len(inter) >= 10
    for c, lc, edge, e in zip(inter, lines[::2], lines[1::2], entries):
        assert lc == f"# LC: {c.score}"
        parts = edge.split()
        assert parts[0] == "EDGE_SE3:QUAT" and len(parts) == 31
        ia, ib = int(parts[1][1:]), int(parts[2][1:])
        assert parts[1][0] + parts[2][0] == "ab" and frames["a"][ia] == c.t_a and frames["b"][ib] == c.t_b
        ns = [EXPORT_EPOCH_NS + round(t * 1e9) for t in (c.t_a, c.t_b)]
        assert e["names"] == ["a", "b"] and e["rotation_convention"] == "xyzw"
        assert e["seconds"] == [n // 10**9 for n in ns] and e["nanoseconds"] == [n % 10**9 for n in ns]
        assert np.allclose([float(v) for v in parts[3:6]], c.T_pa_pb[:3, 3], atol=0)
    intra = sum(1 for c in closures if c.robot_a == c.robot_b)
    n_intra = sum(
        len(json.loads((written / "align" / p / "align.json").read_text(encoding="utf-8"))) for p in ("a_a", "b_b")
    )
    assert n_intra == 2 * intra  # every ordered pair, as the reference's intra-robot loop writes them
    times = (written / "offline_rpgo" / "dense" / "odom_all.time.txt").read_text(encoding="utf-8").splitlines()
    assert len(times) == sum(len(f) for f in frames.values())
    assert times[1] == f"0 1 {EXPORT_EPOCH_NS + round(frames['a'][1] * 1e9)} xxx"


@pytest.mark.parametrize("times", [False, True], ids=["align_json", "timestamps_file"])
def test_the_per_pair_output_gives_the_runs_own_curve(
    smoke_run: RunResult, closures: list[Closure], written: Path, tmp_path: Path, times: bool
) -> None:
    dense = written / "offline_rpgo" / "dense" / "odom_all.time.txt" if times else None
    res = score_external(smoke_run.run_dir, written / "align", tmp_path / "out", times=dense)
    got, mine = res.run.metrics.methods["external"], smoke_run.metrics.methods["roman"]
    for kind in ("inter", "intra"):
        a, b = got.set(kind), mine.set(kind)
        assert a.pr_curve.k.tolist() == b.pr_curve.k.tolist()
        assert a.pr_curve.tp.tolist() == b.pr_curve.tp.tolist()  # the same hits at every threshold
        k3 = a.pr_curve.k >= 3  # below 3 associations the run's results have no pose: no closure
        assert a.pr_curve.fp[k3].tolist() == b.pr_curve.fp[k3].tolist()
        assert a.overall.operating_points == b.overall.operating_points
    assert res.run.ate.variants["external"].rmse == smoke_run.ate.variants["roman"].rmse
    intra = [c for c in closures if c.robot_a == c.robot_b]
    assert res.n_pairs == len(closures) and len(res.unscored) == len(intra)  # each intra pair's second way
    assert all("already has a closure with a score >=" in why for why in res.unscored.values())
    info = read_external(tmp_path / "out")
    assert info.closure_format == "roman_align" and info.n_closures == len(closures) + len(intra)
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert "- a_a/align.g2o:" in report  # an unscored closure named by its file and line


def test_one_pair_file_gives_that_pairs_curve(
    smoke_run: RunResult, closures: list[Closure], written: Path, tmp_path: Path
) -> None:
    res = score_external(smoke_run.run_dir, written / "align" / "a_b" / "align.g2o", tmp_path / "out")
    got, mine = res.run.metrics.methods["external"], smoke_run.metrics.methods["roman"]
    assert got.set("inter").pr_curve.tp.tolist() == mine.set("inter").pr_curve.tp.tolist()
    assert res.n_closures == res.n_pairs == sum(1 for c in closures if c.robot_a != c.robot_b)
    assert got.set("intra").pr_curve.fp[1:].max() == 0  # no intra-robot closure in the a_b file (k = 0: every pair)


def test_the_demos_threshold_cuts_the_curve(smoke_run: RunResult, tmp_path: Path) -> None:
    """Written as the demo writes with -n 4: the curve from k = 4 up is the run's, below it is cut."""
    write_reference_align(smoke_run.run_dir, tmp_path / "n4", min_score=4)
    got = read_align(tmp_path / "n4" / "align", ["a", "b"])
    assert len(got) and int(got.score.min()) >= 4
    res = score_external(smoke_run.run_dir, tmp_path / "n4" / "align", tmp_path / "out")
    a, b = res.run.metrics.methods["external"].set("inter"), smoke_run.metrics.methods["roman"].set("inter")
    k4 = a.pr_curve.k >= 4
    assert a.pr_curve.tp[k4].tolist() == b.pr_curve.tp[k4].tolist()
    assert a.pr_curve.tp[~k4].tolist() == [a.pr_curve.tp[k4][0]] * int((~k4).sum())


def test_bad_per_pair_files(smoke_run: RunResult, written: Path, tmp_path: Path, cli_fails: Callable[..., str]) -> None:
    pair = tmp_path / "align" / "a_b"
    pair.mkdir(parents=True)
    text = (written / "align" / "a_b" / "align.g2o").read_text(encoding="utf-8")
    (pair / "align.g2o").write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "-c", pair / "align.g2o", "-o", out)
    assert err == (
        f"error: {pair / 'align.g2o'}: no align.json beside it (the reference writes both) and no timestamps file: "
        "give the reference's offline_rpgo/dense/odom_all.time.txt with --times"
    )
    (pair / "align.g2o").write_text(text.replace(" b", " c", 1), encoding="utf-8")
    dense = written / "offline_rpgo" / "dense" / "odom_all.time.txt"
    err = cli_fails("score", smoke_run.run_dir, "-c", pair / "align.g2o", "--times", dense, "-o", out)
    first = text.splitlines()[1].split()[2]
    assert (
        err == f"error: {pair / 'align.g2o'}:2: key c{first[1:]}: the second key is b<index> (the pair's second robot)"
    )
    (pair / "align.g2o").write_text(text, encoding="utf-8")
    entries = json.loads((written / "align" / "a_b" / "align.json").read_text(encoding="utf-8"))
    (pair / "align.json").write_text(json.dumps(entries[:-1]), encoding="utf-8")
    err = cli_fails("score", smoke_run.run_dir, "-c", pair / "align.g2o", "-o", out)
    assert err.startswith(f"error: {pair / 'align.json'}: a list of {len(entries)} closures, each with names [run_i, ")
    assert err.endswith(f"(one per edge of align.g2o); got {len(entries) - 1} entries")
    assert not out.exists()
