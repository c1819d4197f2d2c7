"""`roman-sim report RUN --verify`: metrics.json from pairs.csv, ate.json from the TUM files."""

from __future__ import annotations

import shutil

from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.studies.verify import verify_run

runner = CliRunner()


def test_a_fresh_run_verifies(smoke_run):
    res = verify_run(smoke_run.run_dir)
    assert res.ok, res.differences
    assert res.checked == [
        "metrics.json from pairs.csv",
        "ate.json from trajectories/*.tum",
        "every file's SHA-256 against manifest.json",
        "the summary's figures against the independent scorer",
    ]
    out = runner.invoke(app, ["report", str(smoke_run.run_dir), "--verify"])
    assert out.exit_code == 0 and "verified" in out.output


def test_an_edited_pairs_table_or_trajectory_fails_verification(smoke_run, tmp_path):
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    lines = (run_dir / "pairs.csv").read_text().splitlines()
    header = lines[0].split(",")
    col = header.index("correct")
    i = next(i for i, ln in enumerate(lines[1:], 1) if ln.split(",")[col] == "true")
    cells = lines[i].split(",")
    cells[header.index("rot_err_deg")] = "9.0"  # an error beyond 5 deg while the row still says correct
    lines[i] = ",".join(cells)
    (run_dir / "pairs.csv").write_text("\n".join(lines) + "\n")
    res = verify_run(run_dir)
    assert not res.ok and any("correct=True, recomputed False" in d for d in res.differences)
    assert f"{run_dir / 'pairs.csv'} changed after the run wrote it" in " ".join(res.differences)
    out = runner.invoke(app, ["report", str(run_dir), "--verify"])
    assert out.exit_code == 1 and "NOT verified" in out.output
    # a moved trajectory: the ATE no longer matches ate.json
    shutil.copyfile(smoke_run.run_dir / "pairs.csv", run_dir / "pairs.csv")
    tum = run_dir / "trajectories" / "b.roman.tum"
    rows = [r.split() for r in tum.read_text().splitlines()]
    rows[len(rows) // 2][1] = f"{float(rows[len(rows) // 2][1]) + 5.0:.9f}"
    tum.write_text("".join(" ".join(r) + "\n" for r in rows))
    res = verify_run(run_dir)
    edited = [d for d in res.differences if "changed after the run wrote it" in d]
    assert edited == [f"{tum} changed after the run wrote it (its SHA-256 differs from manifest.json's)"]
    others = [d for d in res.differences if d not in edited]
    assert others and all(d.startswith(("ate.json", "independent scorer: /ate/")) for d in others)
    assert any(d.startswith("independent scorer: /ate/roman/") for d in res.differences)


def test_an_edited_estimate_fails_the_independent_check(smoke_run, tmp_path):
    import csv
    import json

    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    with (run_dir / "pairs.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    hits = {
        (r["a"], r["b"]) for r in rows if r["method"] == "roman" and r["correct"] == "true" and r["relevant"] == "true"
    }
    data = json.loads((run_dir / "alignments.json").read_text())
    hit = next(r for r in data["alignments"] if r["method"] == "roman" and (r["a"], r["b"]) in hits)
    hit["T_a_b"][0][3] += 3.0  # 3 m off: no estimate within 1 m is correct any more
    (run_dir / "alignments.json").write_text(json.dumps(data))
    res = verify_run(run_dir)
    # pairs.csv still says what it said (the same-code check passes); the scorer reads the estimate
    assert not any(d.startswith("metrics.json") for d in res.differences)
    assert any(d.startswith("independent scorer: /methods/roman/") for d in res.differences), res.differences


def test_compressed_reference_folders_verify_from_the_cli(smoke_run, tmp_path):
    from roman_sim.studies.reference import collect

    collect(smoke_run.run_dir, tmp_path / "ref")
    out = runner.invoke(app, ["report", str(tmp_path / "ref"), "--verify"])
    assert out.exit_code == 0 and "verified" in out.output, out.output


def test_the_scorer_gives_the_evaluations_operating_points(smoke_run):
    """Every set and heading bin: the independent scorer's points are those of the run's metrics.json."""
    from roman_sim.core.records import to_json
    from roman_sim.report.recompute import stored_summary
    from roman_sim.studies.independent_scorer import agreement, score_run

    scored = score_run(smoke_run.run_dir)
    metrics = smoke_run.metrics
    assert metrics.acceptance_k is not None
    for m, figures in scored["methods"].items():
        for kind in ("inter", "intra"):
            ps = metrics.method(m).set(kind)
            theirs = {n: to_json(p) for n, p in ps.overall.operating_points.items() if p is not None}
            assert not agreement(theirs, figures[kind]["points"]) and set(theirs) == set(figures[kind]["points"])
            for b in ps.heading_bins:
                theirs = {n: to_json(p) for n, p in b.stats.operating_points.items() if p is not None}
                assert not agreement(theirs, figures[kind]["bins"][b.label]["points"]), (m, kind, b.label)
            assert figures[kind]["points"]["acceptance"]["k"] == metrics.acceptance_k
    # the stored summary carries them, and the check compares them
    assert stored_summary(smoke_run.run_dir).methods["roman"].inter.points["max_recall"]
    assert not any("predates" in n for n in verify_run(smoke_run.run_dir).notes)
