"""Stage caching, starting from saved submaps, bring-your-own aligner, report and CLI errors."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.records import from_json, to_json
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.testing import assert_recall, run_scenario

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def test_rerun_reuses_cached_stages(smoke_run):
    again = Experiment(load_scenario("smoke"), smoke_run.run_dir).run()
    assert set(again.reused) == {"maps", "submaps", "evaluation", "posegraph", "ate", "report"}
    assert again.map_stats == smoke_run.map_stats
    assert to_json(again.metrics) == to_json(smoke_run.metrics)
    assert again.notes == smoke_run.notes


def test_manifest_records_the_library_versions_and_a_stage_made_with_others_is_computed_again(
    smoke_run, tmp_path, monkeypatch
):
    from importlib import metadata

    from roman_sim.core import codehash
    from roman_sim.pipeline import experiment as experiment_module
    from roman_sim.pipeline.manifest import MANIFEST_SCHEMA, Manifest, ManifestRecord, environment

    man = json.loads((smoke_run.run_dir / "manifest.json").read_text())
    assert man["environment"] == environment()
    assert man["environment"]["numpy"] == metadata.version("numpy")
    assert man["environment"]["mujoco"] == metadata.version("mujoco")
    assert any(k.startswith("opencv") for k in man["environment"])
    # the same folder resumed with another MuJoCo: every stage whose code imports MuJoCo is computed
    # again, so the manifest's versions are those its stages were made with
    run_dir = tmp_path / "other_env"
    shutil.copytree(smoke_run.run_dir, run_dir)
    real = codehash.library_versions

    def other_mujoco(tops):
        return {k: ("9.9.9" if k == "mujoco" else v) for k, v in real(tops).items()}

    monkeypatch.setattr(codehash, "library_versions", other_mujoco)
    monkeypatch.setattr(experiment_module, "environment", lambda: {**environment(), "mujoco": "9.9.9"})
    again = Experiment(load_scenario("smoke"), run_dir, cache=False).run()
    assert "maps" not in again.reused and "world" not in again.reused
    recorded = json.loads((run_dir / "manifest.json").read_text())
    assert recorded["environment"]["mujoco"] == "9.9.9"
    assert to_json(again.metrics) == to_json(smoke_run.metrics)  # the arithmetic did not change here
    older = {k: v for k, v in man.items() if k != "environment"}  # written before versions were recorded
    assert Manifest.from_record(from_json(ManifestRecord, older, "older", MANIFEST_SCHEMA)).environment == {}


def test_changed_aligners_recompute_only_evaluation(smoke_run, tmp_path):
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    sc = load_scenario("smoke", ["aligners=[roman]"])
    res = Experiment(sc, run_dir).run()
    assert {"maps", "submaps"} <= set(res.reused)
    assert "evaluation" not in res.reused
    assert list(res.metrics.methods) == ["roman"]


def test_start_from_saved_submaps(smoke_run, tmp_path):
    res = Experiment(load_scenario("smoke"), tmp_path / "from_submaps", submaps_dir=smoke_run.run_dir / "submaps").run()
    assert res.metrics.figure("roman", key="n_relevant") == smoke_run.metrics.figure("roman", key="n_relevant")
    assert res.recall("roman") == smoke_run.recall("roman")
    assert any("pose graph skipped" in n for n in res.notes)


def test_user_aligner_runs_through_the_same_pipeline(smoke_run, monkeypatch, tmp_path):
    monkeypatch.syspath_prepend(str(ROOT))
    shutil.copytree(smoke_run.run_dir, tmp_path / "byo" / "seed0")  # reuse the rendered stages
    run = run_scenario("smoke", aligners=["examples.mutual_nn_aligner:MutualNNAligner"], out=tmp_path / "byo")
    assert "MutualNNAligner" in run.metrics.methods
    assert {"roman", "clipper"} <= set(run.metrics.methods)
    assert "maps" in run.reused
    report = (run.run_dir / "report.md").read_text()
    assert "MutualNNAligner" in report
    assert_recall(run, "roman", 0.1)
    with pytest.raises(AssertionError, match="MutualNNAligner max_recall"):
        assert_recall(run, "examples.mutual_nn_aligner:MutualNNAligner", 1.0)  # bounds lie in [0, 1]


def test_run_folder_contents(smoke_run):
    d = smoke_run.run_dir
    for name in (
        "config.yaml",
        "manifest.json",
        "metrics.json",
        "pairs.csv",
        "alignments.json",
        "report.md",
        "ate.json",
        "posegraph.json",
        "map_stats.json",
        "timings.json",
    ):
        assert (d / name).is_file(), name
    for robot in ("a", "b"):
        for variant in ("truth", "odometry", "roman", "oracle"):
            assert (d / "trajectories" / f"{robot}.{variant}.tum").is_file()
    for plot in (
        "trajectories",
        "segments_on_image",
        "recall_heading",
        "precision_recall_heading",
        "association_heading",
        "alignment_roman",
        "alignment_clipper",
    ):
        assert (d / "plots" / f"{plot}.png").stat().st_size > 1000, plot
    assert not list(d.rglob("*.tmp"))
    stages = json.loads((d / "timings.json").read_text())["stages"]
    assert stages["maps"]["seconds"] > 0 and stages["maps"]["peak_rss_mb"] > 0
    assert stages["evaluation"]["alignment"]["roman"]["median"] > 0
    manifest = json.loads((d / "manifest.json").read_text())
    assert manifest["complete"]
    assert sorted(manifest["stages"]) == ["ate", "evaluation", "maps", "posegraph", "report", "submaps"]
    listed = {f for rec in manifest["stages"].values() for f in rec["files"]}
    assert {"maps/a.npz", "maps/b.npz", "submaps/a.npz", "plots/trajectories.png", "report.md"} <= listed
    assert all((d / f).is_file() for f in listed)


def test_report_command_prints_summary(smoke_run):
    res = runner.invoke(app, ["report", str(smoke_run.run_dir)])
    assert res.exit_code == 0, res.output
    assert "roman" in res.output and "ATE" in res.output
    assert "cross-robot (headline) pairs" in res.output and "same-robot pairs" in res.output
    assert "no distance cap" in res.output and "odometry_no_prior" in res.output


def _one_line_error(res) -> str:
    assert res.exit_code == 1, res.output
    assert "Traceback" not in res.output
    lines = [ln for ln in res.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, res.output
    return lines[0]


def test_cli_unknown_key(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nrobots: [{name: a}]\nfrontend: {segmentr: perfect}\n")
    line = _one_line_error(runner.invoke(app, ["run", str(bad), "--out", str(tmp_path / "o")]))
    assert "frontend.segmentr" in line and "unknown key" in line


def test_cli_bad_value_and_unknown_preset(tmp_path):
    line = _one_line_error(runner.invoke(app, ["run", "smoke", "--set", "seed=-3", "--out", str(tmp_path)]))
    assert "seed" in line
    line = _one_line_error(runner.invoke(app, ["run", "smoke", "--set", "world.preset=moon", "--out", str(tmp_path)]))
    assert "moon" in line and "tiny" in line
    line = _one_line_error(runner.invoke(app, ["run", "smoke", "--set", "aligners=[nope]", "--out", str(tmp_path)]))
    assert "nope" in line and "roman" in line


def test_cli_missing_scenario_and_unwritable_out(tmp_path):
    line = _one_line_error(runner.invoke(app, ["run", str(tmp_path / "none.yaml")]))
    assert "none.yaml" in line
    blocker = tmp_path / "file"
    blocker.write_text("")
    line = _one_line_error(runner.invoke(app, ["run", "smoke", "--out", str(blocker / "sub")]))
    sub = blocker / "sub"
    assert line == f"error: --out {sub}: lies inside {blocker}, an existing file, not a folder (choose a folder path)"


def test_cli_report_on_missing_run(tmp_path):
    line = _one_line_error(runner.invoke(app, ["report", str(tmp_path)]))
    assert "manifest.json" in line and "not a run folder" in line


def test_list_scenarios_and_aligners():
    res = runner.invoke(app, ["list", "scenarios"])
    assert res.exit_code == 0 and "smoke" in res.output
    res = runner.invoke(app, ["list", "aligners"])
    assert "roman" in res.output and "ransac1m" in res.output


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios" / "sweeps").glob("*.yaml")), ids=lambda p: p.stem)
def test_every_bundled_sweep_validates(path):
    from roman_sim.pipeline.sweep import expand, load_sweep

    cfg, scenario = load_sweep(path)
    runs = expand(cfg)
    assert runs
    for run in runs[:3]:
        load_scenario(scenario, list(run.overrides) + [f"seed={run.seed}"]).world.spec()


def test_reproduce_collects_results_with_their_raw_data(smoke_run, tmp_path):
    from roman_sim.studies.reference import rederive, reproduce
    from roman_sim.studies.verify import verify_run

    shutil.copytree(smoke_run.run_dir, tmp_path / "work" / "smoke")
    path = reproduce(tmp_path / "ref", ["smoke"], tmp_path / "work")
    dest = tmp_path / "ref" / "smoke"
    assert (dest / "metrics.json").is_file() and (dest / "report.md").is_file()
    assert (dest / "plots" / "precision_recall.png").is_file() and not (dest / "plots" / "map_view.png").exists()
    for raw in ("pairs.csv.gz", "alignments.json.gz", "trajectories/a.roman.tum.gz", "trajectories/b.truth.tum.gz"):
        assert (dest / raw).is_file(), raw
    assert not (dest / "maps").exists() and not (dest / "pairs.csv").exists()
    assert verify_run(dest, pairs_file="pairs.csv.gz", tum_suffix=".gz").ok
    summary = json.loads((tmp_path / "ref" / "summary.json").read_text())
    again = rederive(tmp_path / "ref")  # the whole summary follows from the collected raw files
    assert json.loads(json.dumps(to_json(again), sort_keys=True)) == summary
    text = path.read_text()
    assert "map size (MB per km)" in text
    assert f"{smoke_run.map_stats.mb_per_km:.2f}" in text
    assert "| roman max recall, same direction | 0.67 | n/a | n/a |" in text  # not run here: not computable


def test_reproduce_of_the_default_set_keeps_the_runs_it_does_not_run(smoke_run, tmp_path, monkeypatch):
    """The paper-scale runs are run on request: a default reproduce keeps their committed results."""
    from roman_sim.studies import reference

    shutil.copytree(smoke_run.run_dir, tmp_path / "work" / "smoke")
    reference.reproduce(tmp_path / "ref", ["smoke"], tmp_path / "work")  # committed: smoke
    before = json.loads((tmp_path / "ref" / "summary.json").read_text())
    # a default set without smoke (the demo re-collected from its cached run, no sweep)
    monkeypatch.setattr(reference, "PAPER_SCENARIOS", [])
    monkeypatch.setattr(reference, "DEMO", "smoke")
    monkeypatch.setattr(reference, "ambiguity_sweep", lambda *a, **k: [])
    reference.reproduce(tmp_path / "ref", None, tmp_path / "work")
    after = json.loads((tmp_path / "ref" / "summary.json").read_text())
    assert list(after["runs"]) == ["smoke"] and after["runs"] == before["runs"]


def test_record_command_stores_readable_frames(tmp_path):
    from roman_sim.core.tum import read_tum
    from roman_sim.sim.recording import read_recording, recording_info

    out = tmp_path / "rec"
    res = runner.invoke(
        app, ["record", "smoke", "--out", str(out), "--robot", "b", "--set", "robots.1.max_length_m=2.0"]
    )
    assert res.exit_code == 0, res.output
    assert not (out / "a").exists()
    info = recording_info(out / "b")
    frames = list(read_recording(out / "b"))
    assert len(frames) == info.frame_count > 5 and info.extra is not None and info.extra.scenario == "smoke"
    assert frames[0].depth.shape == (120, 160) and frames[0].robot == "b"
    assert len(read_tum(out / "b" / "traj_odom.tum")) == len(frames)
    line = _one_line_error(runner.invoke(app, ["record", "smoke", "--out", str(out), "--robot", "zz"]))
    assert "zz" in line and "a, b" in line


def test_from_stage_recomputes_later_stages_only(smoke_run, tmp_path):
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    res = Experiment(load_scenario("smoke"), run_dir, from_stage="evaluation").run()
    assert set(res.reused) == {"maps", "submaps"}
    assert res.recall("roman") == smoke_run.recall("roman")
    line = _one_line_error(runner.invoke(app, ["run", "smoke", "--from", "nope", "--out", str(run_dir)]))
    assert "nope" in line and "evaluation" in line


def test_sweep_markdown_table():
    from roman_sim.studies.claims import SweepRow, sweep_markdown

    rows = [
        SweepRow(ambiguity=0.0, method="roman", recall=0.7, hits=7, relevant=10, ci=(0.4, 0.89), n_seeds=1),
        SweepRow(ambiguity=0.0, method="clipper", recall=0.5, hits=1, relevant=2, ci=(0.09, 0.91), n_seeds=1),
        SweepRow(ambiguity=1.0, method="roman", recall=None, hits=0, relevant=0, ci=None, n_seeds=1),
    ]
    text = sweep_markdown(rows)
    assert "| ambiguity | clipper | roman |" in text
    assert "| 0 | n<5: 1/2 | 0.70 (7/10) [0.40, 0.89] |" in text and "| 1 | n/a | n/a |" in text
    assert sweep_markdown([]) == ""


def test_user_segmenter_and_encoder_run_through_the_pipeline(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT))
    sets = [
        "robots.0.max_length_m=12",
        "robots.1.max_length_m=12",
        "frontend.segmenter=examples.depth_segmenter:DepthEdgeSegmenter",
        "frontend.encoder=examples.depth_segmenter:ShapeEncoder",
    ]
    res = Experiment(load_scenario("smoke", sets), tmp_path / "byo").run()
    assert res.map_stats.segments > 0
    from roman_sim.mapping.io import load_submaps

    subs = load_submaps(tmp_path / "byo" / "submaps" / "a.npz")
    assert any(len(s) for s in subs)
    assert {s.descriptors.shape[1] for s in subs if len(s)} == {8}
    line = _one_line_error(
        runner.invoke(
            app, ["run", "smoke", "--out", str(tmp_path / "x"), "--set", "frontend.encoder=examples.nope:Enc"]
        )
    )
    assert "examples.nope" in line


class _Interrupting:
    """An aligner that stops the run like Ctrl-C in the middle of the evaluation."""

    name = "interrupting"

    def align(self, a, b):
        raise KeyboardInterrupt


def test_interrupted_run_keeps_completed_stages(smoke_run, tmp_path):
    from roman_sim.align import ALIGNERS

    """A changed configuration interrupted mid-way: the folder says it is incomplete (no stale
    metrics are reported under the new config.yaml); the next run completes it from the kept stages."""
    from roman_sim.core.errors import StorageError
    from roman_sim.pipeline.result import RunResult

    run_dir = tmp_path / "interrupted"
    shutil.copytree(smoke_run.run_dir, run_dir)
    ALIGNERS.register("interrupting", _Interrupting)
    try:
        with pytest.raises(KeyboardInterrupt):
            Experiment(load_scenario("smoke", ["aligners=[roman, interrupting]"]), run_dir).run()
    finally:
        ALIGNERS._items.pop("interrupting", None)
    assert not list(run_dir.rglob("*.tmp"))  # no half-written file
    assert not (run_dir / "metrics.json").exists()  # the old configuration's results are gone with it
    with pytest.raises(StorageError, match="stages missing: evaluation, posegraph, ate, report"):
        RunResult.load(run_dir)
    line = _one_line_error(runner.invoke(app, ["report", str(run_dir)]))
    assert "did not complete" in line
    res = Experiment(load_scenario("smoke"), run_dir).run()
    assert {"maps", "submaps"} <= set(res.reused) and "evaluation" not in res.reused
    assert to_json(res.metrics) == to_json(smoke_run.metrics)
    assert to_json(RunResult.load(run_dir).metrics) == to_json(smoke_run.metrics)
