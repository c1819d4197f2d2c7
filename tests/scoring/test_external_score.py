"""``roman-sim score``: a run's own closures, written as CSV and g2o, read back give the run's figures.

Bad input: one line naming the file, the line and what is allowed; nothing written.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from pathlib import Path

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from roman_sim.core.geometry import rot_z
from roman_sim.core.records import to_json
from roman_sim.core.tum import read_tum
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import compute_metrics
from roman_sim.evaluation.results import read_evaluation
from roman_sim.interop.closures import Closure, write_csv_closures, write_g2o_closures
from roman_sim.pipeline.result import RunResult
from roman_sim.scoring.external import EXTERNAL_ATE_JSON, read_external, run_closures, score_external


@pytest.fixture(scope="module")
def closures(smoke_run: RunResult) -> list[Closure]:
    return run_closures(smoke_run.run_dir, "roman")


@pytest.fixture(scope="module")
def files(closures: list[Closure], tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("closures")
    write_csv_closures(d / "roman.csv", closures)
    write_g2o_closures(d / "roman.g2o", d / "roman.time.txt", closures, ["a", "b"])
    return {"csv": d / "roman.csv", "g2o": d / "roman.g2o", "times": d / "roman.time.txt", "dir": d}


@pytest.fixture(scope="module")
def scored(smoke_run: RunResult, files: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The run's ROMAN closures scored from CSV (with the run's own trajectories) and from g2o."""
    out = tmp_path_factory.mktemp("scored")
    traj = out / "traj"
    traj.mkdir()
    for r in ("a", "b"):
        (traj / f"{r}.tum").write_bytes((smoke_run.run_dir / "trajectories" / f"{r}.roman.tum").read_bytes())
    score_external(smoke_run.run_dir, files["csv"], out / "csv", trajectories=traj, label="ext")
    ref = out / "ref"  # the same trajectories as the reference ROMAN writes them (CSV, ns, qw first)
    ref.mkdir()
    for r in ("a", "b"):
        tr = read_tum(traj / f"{r}.tum")
        q = Rotation.from_matrix(tr.T[:, :3, :3]).as_quat()
        rows = [
            ",".join([str(round(t * 1e9)), *(repr(float(v)) for v in (*p, w[3], *w[:3]))])
            for t, p, w in zip(tr.t, tr.positions, q)
        ]
        (ref / f"{r}.csv").write_text("#timestamp_kf,x,y,z,qw,qx,qy,qz\n" + "\n".join(rows) + "\n", encoding="utf-8")
    score_external(smoke_run.run_dir, files["g2o"], out / "g2o", times=files["times"], trajectories=ref, label="ext")
    return {"csv": out / "csv", "g2o": out / "g2o"}


def _carried(run_dir: Path, label: str):  # type: ignore[no-untyped-def]
    """The run's roman metrics recomputed from what a closure file carries.

    A closure has a pose: a result with associations but no pose (too few for a transform)
    is no closure, so it counts as 0 associations; an external system's associations are not
    segment pairs, so they are not graded.
    """
    scores, metrics = read_evaluation(run_dir)
    mine = [
        dataclasses.replace(
            s,
            method=label,
            n_assoc=0 if math.isnan(s.rot_err_deg) else s.n_assoc,
            assoc_correct=-1,
            assoc_recovered=-1,
        )
        for s in scores
        if s.method == "roman"
    ]
    cfg = EvalConfig.model_validate(metrics.config)
    return compute_metrics(mine, cfg, metrics.n_skipped, metrics.acceptance_k), metrics


@pytest.mark.parametrize("fmt", ["csv", "g2o"])
def test_round_trip_gives_the_runs_own_figures(
    smoke_run: RunResult, closures: list[Closure], scored: dict[str, Path], fmt: str
) -> None:
    run = RunResult.load(scored[fmt])
    assert [a.name for a in run.scenario.aligners] == ["ext"]
    expected, own = _carried(smoke_run.run_dir, "ext")
    got = run.metrics.methods["ext"]
    assert to_json(got) == to_json(expected.methods["ext"])  # every figure, exactly
    # and against the run's own metrics: every operating point, every recall, every hit count
    mine = own.methods["roman"]
    for kind in ("inter", "intra"):
        a, b = got.set(kind), mine.set(kind)
        assert a.overall.operating_points == b.overall.operating_points
        assert (a.overall.max_hits, a.overall.hits_at_precision_1) == (
            b.overall.max_hits,
            b.overall.hits_at_precision_1,
        )
        assert a.pr_curve.tp.tolist() == b.pr_curve.tp.tolist()
        k3 = a.pr_curve.k >= 3  # below 3 associations the run's results have no pose: no closure
        assert a.pr_curve.fp[k3].tolist() == b.pr_curve.fp[k3].tolist()
        assert [r.stats.max_hits for r in a.heading_bins] == [r.stats.max_hits for r in b.heading_bins]
        assert [r.stats.operating_points for r in a.heading_bins] == [r.stats.operating_points for r in b.heading_bins]
    # ATE of the pose graph with the closures: the run's roman row, to the last digit
    ate = {v: r.rmse for v, r in run.ate.variants.items()}
    assert ate["ext"] == smoke_run.ate.variants["roman"].rmse
    with_pose = [
        s for s in read_evaluation(smoke_run.run_dir)[0] if s.method == "roman" and not math.isnan(s.rot_err_deg)
    ]
    assert len(closures) == len(with_pose)
    info = read_external(scored[fmt])
    assert info.n_closures == info.n_pairs == len(closures) and info.unscored == {}
    text = (scored[fmt] / "report.md").read_text(encoding="utf-8")
    assert "## External system" in text and "`ext` is an external system" in text


def test_per_pair_errors_match_the_run(smoke_run: RunResult, scored: dict[str, Path]) -> None:
    own = {(s.truth.a, s.truth.b): s for s in read_evaluation(smoke_run.run_dir)[0] if s.method == "roman"}
    for s in read_evaluation(scored["g2o"])[0]:
        o = own[(s.truth.a, s.truth.b)]
        if math.isnan(o.rot_err_deg):
            assert s.n_assoc == 0 and math.isnan(s.rot_err_deg)
            continue
        assert s.n_assoc == o.n_assoc and s.correct == o.correct
        assert s.rot_err_deg == pytest.approx(o.rot_err_deg, abs=1e-6)
        assert s.trans_err_m == pytest.approx(o.trans_err_m, abs=1e-8)


@pytest.mark.parametrize("fmt", ["csv", "g2o"])  # TUM trajectories with the CSV closures, the reference's CSV with g2o
def test_own_trajectories_scored_like_the_runs_pose_graph(
    smoke_run: RunResult, scored: dict[str, Path], fmt: str
) -> None:
    data = json.loads((scored[fmt] / EXTERNAL_ATE_JSON).read_text(encoding="utf-8"))
    (row,) = data["variants"]
    assert row["name"] == "ext_trajectories" and row["connected"] == ["a", "b"]
    own = smoke_run.ate.variants["roman"].rmse
    for fit in ("se3", "4dof"):
        for cell in ("a", "b", "all"):
            assert row["rmse"][fit][cell] == pytest.approx(own[fit][cell], abs=1e-6)


def test_wrong_closures_are_false_positives(smoke_run: RunResult, closures: list[Closure], tmp_path: Path) -> None:
    """Accepted closures turned by 90 degrees are wrong: no hit is left, each correct one is one more false positive."""
    own_scores = [s for s in read_evaluation(smoke_run.run_dir)[0] if s.method == "roman"]
    k = smoke_run.metrics.acceptance_k
    assert k is not None
    turn = np.eye(4)
    turn[:3, :3] = rot_z(np.pi / 2)
    bad = [dataclasses.replace(c, T_pa_pb=c.T_pa_pb @ turn) if (c.score or 0) >= k else c for c in closures]
    assert sum(1 for c in closures if (c.score or 0) >= k) >= 5
    write_csv_closures(tmp_path / "bad.csv", bad)
    res = score_external(smoke_run.run_dir, tmp_path / "bad.csv", tmp_path / "out")
    got, was = res.run.metrics.methods["external"], smoke_run.metrics.methods["roman"]
    n_correct = sum(1 for s in own_scores if s.correct and s.n_assoc >= k)
    assert n_correct >= 5
    points = [
        (got.set(s).overall.operating_points["acceptance"], was.set(s).overall.operating_points["acceptance"])
        for s in ("inter", "intra")
    ]
    assert all(g is not None and w is not None for g, w in points)
    assert [g.hits for g, _ in points] == [0, 0]  # type: ignore[union-attr]
    fp_got = sum(g.false_positives for g, _ in points)  # type: ignore[union-attr]
    fp_was = sum(w.false_positives for _, w in points)  # type: ignore[union-attr]
    assert fp_got == fp_was + n_correct


def _fused_g2o(run_dir: Path, closures: list[Closure], k: int, out: Path) -> None:
    """The reference demo's fused file: a vertex per frame, odometry edges, accepted closures without comments."""
    import gtsam

    from roman_sim.interop.closures import xyz_quat
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.pipeline.stages.maps import MapsStage
    from roman_sim.scoring.external import _load_stage

    maps = _load_stage(run_dir, load_scenario(run_dir / "config.yaml"), MapsStage())
    info = " ".join(["1"] * 21)
    lines, times, key = [], [], {}
    for i, r in enumerate(("a", "b")):
        od = maps.maps[r].odometry
        for j, (t, T) in enumerate(zip(od.t, od.T)):
            key[(r, round(t * 1e9))] = gtsam.symbol(chr(ord("a") + i), j)
            lines.append(f"VERTEX_SE3:QUAT {key[(r, round(t * 1e9))]} {' '.join(map(repr, xyz_quat(T)))}")
            times.append(f"{i} {j} {round(t * 1e9)} x")
            if j:
                rel = np.linalg.inv(od.T[j - 1]) @ T
                prev = gtsam.symbol(chr(ord("a") + i), j - 1)
                lines.append(
                    f"EDGE_SE3:QUAT {prev}\t{key[(r, round(t * 1e9))]}\t{' '.join(map(repr, xyz_quat(rel)))}\t{info}"
                )
    for c in closures:
        if (c.score or 0) >= k:
            ka, kb = key[(c.robot_a, round(c.t_a * 1e9))], key[(c.robot_b, round(c.t_b * 1e9))]
            lines.append(f"EDGE_SE3:QUAT {ka} {kb}\t{' '.join(map(repr, xyz_quat(c.T_pa_pb)))}\t{info}")
    (out / "odom_and_lc.g2o").write_text("\n".join(lines) + "\n", encoding="utf-8")
    (out / "odom_all.time.txt").write_text("\n".join(times) + "\n", encoding="utf-8")


def test_reference_fused_layout_gives_the_acceptance_point(
    smoke_run: RunResult, closures: list[Closure], tmp_path: Path
) -> None:
    """The demo's fused g2o (odometry edges skipped, accepted closures only): the run's acceptance point and ATE."""
    k = smoke_run.metrics.acceptance_k
    assert k is not None
    _fused_g2o(smoke_run.run_dir, closures, k, tmp_path)
    res = score_external(
        smoke_run.run_dir, tmp_path / "odom_and_lc.g2o", tmp_path / "out", times=tmp_path / "odom_all.time.txt"
    )
    assert res.n_closures == sum(1 for c in closures if (c.score or 0) >= k) and res.unscored == {}
    got, was = res.run.metrics.methods["external"], smoke_run.metrics.methods["roman"]
    for kind in ("inter", "intra"):
        assert (
            got.set(kind).overall.operating_points["acceptance"] == was.set(kind).overall.operating_points["acceptance"]
        )
    assert res.run.ate.variants["external"].rmse == smoke_run.ate.variants["roman"].rmse


def test_a_pair_keeps_its_first_closure_of_the_highest_score(
    smoke_run: RunResult, closures: list[Closure], tmp_path: Path
) -> None:
    """One closure written 26 times with other scores, and one whose ends fall in one submap: every
    line's fate by hand; the report lists the first 20 unscored lines, external.json all of them."""
    c = next(x for x in closures if x.robot_a != x.robot_b)
    scores = [4, 4, 6, 5, *([2] * 22)]  # lines 2..27: equal, higher (keeps), lower, then 22 lower ones
    rows = [dataclasses.replace(c, score=n) for n in scores] + [dataclasses.replace(c, robot_b=c.robot_a, t_b=c.t_a)]
    write_csv_closures(tmp_path / "dup.csv", rows)
    res = score_external(smoke_run.run_dir, tmp_path / "dup.csv", tmp_path / "out")
    from roman_sim.pipeline.stages.submaps import SubmapsStage
    from roman_sim.scoring.external import _load_stage

    subs = _load_stage(smoke_run.run_dir, smoke_run.scenario, SubmapsStage()).submaps
    name = {(s.robot, s.t): s.name for robot in subs.values() for s in robot}  # the run's closures join centres
    a, b = name[(c.robot_a, c.t_a)], name[(c.robot_b, c.t_b)]
    pair = "|".join(sorted([a, b]))  # two robots: the robot's name orders the pair
    expected = {
        2: f"pair {pair} has a closure with a higher score (line 4)",
        3: f"pair {pair} already has a closure with a score >= 4",
        **{line: f"pair {pair} already has a closure with a score >= {n}" for line, n in zip(range(5, 28), scores[3:])},
        28: f"both ends fall in submap {a}",
    }
    assert res.n_pairs == 1 and dict(res.unscored.items()) == expected
    assert read_external(tmp_path / "out").unscored == {str(k): v for k, v in expected.items()}
    report = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    listed = [ln for ln in report.splitlines() if ln.startswith("- line ")]
    assert listed == [f"- line {k}: {v}" for k, v in sorted(expected.items())[:20]]
    assert f"- and {len(expected) - 20} more (every one in `external.json`)" in report


# -- bad input ---------------------------------------------------------------------------

GOOD = "a,10.0,b,20.0,1.0,2.0,0.0,0.0,0.0,0.0,1.0,7"
INFO = " ".join(["1"] * 21)


def _g2o(key_a: str, key_b: str, quat: str = "0 0 0 1") -> str:
    return f"# LC: 5\nEDGE_SE3:QUAT {key_a} {key_b} 1 2 0 {quat} {INFO}\n"


A0, B3, C1 = gtsam.symbol("a", 0), gtsam.symbol("b", 3), gtsam.symbol("c", 1)
TIMES = "0 0 10000000000 a\n1 3 20000000000 b\n2 1 5000000000 c\n"

CSV_CASES = {
    "unknown robot": ("a,10.0,z,20.0,1,2,0,0,0,0,1,7", ":2: robot 'z' is not a robot of the run (allowed: a, b)"),
    "time outside": (
        "a,10.0,b,999.0,1,2,0,0,0,0,1,7",
        ":2: time 999.000000 s of robot b matches no frame within 0.01 s (nearest frame 89.166667 s, 909.833333 s "
        "before it; the robot's frames run 0.000000 to 89.166667 s, every 0.166667 s; the file's clock: seconds since "
        "the robot's start)",
    ),
    "between frames": (
        "a,10.05,b,20.0,1,2,0,0,0,0,1,7",
        ":2: time 10.050000 s of robot a matches no frame within 0.01 s (nearest frame 10.000000 s, 0.050000 s before",
    ),
    "nanoseconds": (  # beside the seconds of the next line: two clocks, named as nanoseconds
        "a,10000000000,b,20000000000,1,2,0,0,0,0,1,7",
        ":3: time 10.000000 s is on another clock than line 2's 10000000000.000000 s (allowed: every stamp since the "
        "robot's start, below 1e+09 s, or every stamp on the export's clock, since 1970); the file's stamps look like "
        "nanoseconds since the start",
    ),
    "nanoseconds since the start": (  # all below 1e9: one clock, the stamp matches no frame
        "a,166666667,b,20.0,1,2,0,0,0,0,1,7",
        ":2: time 166666667.000000 s of robot a matches no frame within 0.01 s (nearest frame 89.166667 s, "
        "166666577.833333 s before it; the robot's frames run 0.000000 to 89.166667 s, every 0.166667 s; the file's "
        "clock: seconds since the robot's start); it looks like nanoseconds (166666667 ns is 0.166667 s, a frame's "
        "time)",
    ),
    "nanoseconds since 1970": (
        "a,1700000010000000000,b,20.0,1,2,0,0,0,0,1,7",
        ":2: field t_a: 1.7e+18 s is out of range (allowed: a magnitude of at most 1e+11 s); it looks like nanoseconds",
    ),
    "mixed clocks": (
        "a,1700000010.0,b,1700000020.0,1,2,0,0,0,0,1,7",
        ":3: time 10.000000 s is on another clock than line 2's 1700000010.000000 s (allowed: every stamp since the "
        "robot's start, below 1e+09 s, or every stamp on the export's clock, since 1970)",
    ),
    "negative time": ("a,-1,b,20,1,2,0,0,0,0,1,7", ":2: t_a: -1.0 s is negative"),
    "non-rigid": (
        "a,10.0,b,20.0,1,2,0,0,0,0.5,0.5,7",
        ":2: quaternion norm 0.707107: a rigid relative pose needs a unit",
    ),
    "short line": ("a,10.0,b,20.0,1,2,0,0,0,1", ":2: 10 fields; a closure line is robot_a,t_a,robot_b,t_b,"),
    "not a number": ("a,10.0,b,20.0,1,two,0,0,0,0,1,7", ":2: relative pose: not a number in"),
    "bad score": ("a,10.0,b,20.0,1,2,0,0,0,0,1,many", ":2: score 'many': must be a whole number"),
    "huge pose": ("a,10.0,b,20.0,1e308,2,0,0,0,0,1,7", ":2: field x: 1e+308 m is out of range (allowed: a magnitude"),
    "nan pose": ("a,10.0,b,20.0,1,nan,0,0,0,0,1,7", ":2: field y: nan is not a finite number"),
    "inf time": ("a,inf,b,20.0,1,2,0,0,0,0,1,7", ":2: field t_a: inf is not a finite number"),
}


@pytest.mark.parametrize("case", sorted(CSV_CASES))
def test_bad_csv_line(smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str], case: str) -> None:
    line, message = CSV_CASES[case]
    path = tmp_path / "c.csv"
    path.write_text(f"robot_a,t_a,robot_b,t_b,x,y,z,qx,qy,qz,qw,score\n{line}\n{GOOD}\n", encoding="utf-8")
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "--closures", path, "--out", out)
    assert err.startswith(f"error: {path}{message}"), err
    assert not out.exists()


G2O_CASES = {
    "unknown symbol": (
        _g2o(str(A0), str(C1)),
        ":2: key of Symbol character 'c': no such robot (allowed: 'a' (a), 'b' (b))",
    ),
    "non-rigid": (_g2o(str(A0), str(B3), "0 0 0.6 0.6"), ":2: quaternion norm 0.848528: a rigid relative pose"),
    "short edge": (
        f"EDGE_SE3:QUAT {A0} {B3} 1 2 0 0 0 0 1\n",
        ":1: EDGE_SE3:QUAT needs key1 key2 x y z qx qy qz qw and 21",
    ),
    "text keys": (
        _g2o(str(A0), str(B3)) + _g2o("a0", "b3"),
        ":4: EDGE_SE3:QUAT: keys must be whole numbers (gtsam Symbol keys), got a0 b3",
    ),
    "other tag": ("EDGE_SE2 0 1 1 2 0 1 0 0 1 0 1\n", ":1: unsupported tag 'EDGE_SE2' (allowed: VERTEX_SE3:QUAT"),
    "no time": (_g2o(str(A0), str(gtsam.symbol("b", 9))), ":2: keyframe 9 of robot b (id 1) has no time"),
}


@pytest.mark.parametrize("case", sorted(G2O_CASES))
def test_bad_g2o_line(smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str], case: str) -> None:
    text, message = G2O_CASES[case]
    path, times = tmp_path / "c.g2o", tmp_path / "c.time.txt"
    path.write_text(text, encoding="utf-8")
    times.write_text(TIMES, encoding="utf-8")
    out = tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "--closures", path, "--times", times, "--out", out)
    assert err.startswith(f"error: {path}{message}"), err
    assert not out.exists()


def test_g2o_needs_its_times(smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str]) -> None:
    path = tmp_path / "c.g2o"
    path.write_text(_g2o(str(A0), str(B3)), encoding="utf-8")
    err = cli_fails("score", smoke_run.run_dir, "--closures", path, "--out", tmp_path / "out")
    assert err == f"error: --closures {path}: a g2o file needs its timestamps file (--times)"


def _own_trajectories(smoke_run: RunResult, tmp_path: Path, edit_b: Callable[[list[str]], list[str]]) -> Path:
    """A closure file and the run's ROMAN trajectories as the system's own, robot b's lines edited."""
    (tmp_path / "c.csv").write_text(GOOD + "\n", encoding="utf-8")
    traj = tmp_path / "traj"
    traj.mkdir()
    for r in ("a", "b"):
        rows = (smoke_run.run_dir / "trajectories" / f"{r}.roman.tum").read_text(encoding="utf-8").splitlines()
        (traj / f"{r}.tum").write_text("\n".join(edit_b(rows) if r == "b" else rows) + "\n", encoding="utf-8")
    return traj


def test_trajectories_that_do_not_cover_the_run(
    smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    traj = _own_trajectories(smoke_run, tmp_path, lambda rows: rows[: len(rows) // 2])
    closures, out = tmp_path / "c.csv", tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--trajectories", traj, "--out", out)
    assert err.startswith(f"error: {traj / 'b.tum'}: covers 0.000 to "), err
    assert "robot b runs 0.000 to " in err and "(allowed: from at most 1 s after its first frame" in err
    assert not out.exists()
    (traj / "b.tum").unlink()
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--trajectories", traj, "--out", out)
    assert err.startswith(f"error: --trajectories {traj}: no b.tum or b.csv (one file per robot: a.tum, b.tum, or ")
    (traj / "b.csv").write_text("time,x,y,z\n", encoding="utf-8")
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--trajectories", traj, "--out", out)
    assert err == f"error: {traj / 'b.csv'}:1: a trajectory CSV starts with the header #timestamp_kf,x,y,z,qw,qx,qy,qz"


def test_source_and_out_checked(smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str]) -> None:
    closures = tmp_path / "c.csv"
    closures.write_text(GOOD + "\n", encoding="utf-8")
    err = cli_fails("score", tmp_path, "--closures", closures, "--out", tmp_path / "out")
    assert err == f"error: {tmp_path}: neither a run folder (manifest.json) nor an export folder (export.json)"
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--out", smoke_run.run_dir)
    assert err == f"error: --out {smoke_run.run_dir}: already holds files (choose a new folder)"
    err = cli_fails("score", smoke_run.run_dir, "--closures", tmp_path / "c.txt", "--out", tmp_path / "o")
    assert err == f"error: --closures {tmp_path / 'c.txt'}: no such file"


def test_a_trajectory_value_out_of_range_is_one_line(
    smoke_run: RunResult, tmp_path: Path, cli_fails: Callable[..., str]
) -> None:
    """A pose of 1e308 in the system's own trajectory: its file and line, before anything is written."""

    def huge(rows: list[str]) -> list[str]:
        cells = rows[3].split()
        return [*rows[:3], " ".join([cells[0], "1e308", *cells[2:]]), *rows[4:]]

    traj = _own_trajectories(smoke_run, tmp_path, huge)
    closures, out = tmp_path / "c.csv", tmp_path / "out"
    err = cli_fails("score", smoke_run.run_dir, "--closures", closures, "--trajectories", traj, "--out", out)
    assert err == (
        f"error: {traj / 'b.tum'}:4: field tx: 1e+308 m is out of range (allowed: a magnitude of at most 1e+09 m)"
    )
    assert not out.exists()
