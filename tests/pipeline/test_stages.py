"""Stages on their own (typed outputs, save/load, keys) and a run folder that never reports stale state."""

from __future__ import annotations

import json
import shutil

import pytest

from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.records import to_json
from roman_sim.mapping.io import save_submaps
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.manifest import read_manifest
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages import STAGE_NAMES, STAGES
from roman_sim.pipeline.stages.ate import AteStage
from roman_sim.pipeline.stages.base import NoInputs
from roman_sim.pipeline.stages.evaluation import EvaluationInputs, EvaluationStage
from roman_sim.pipeline.stages.posegraph import PoseGraphStage
from roman_sim.pipeline.stages.report import ReportStage
from roman_sim.pipeline.stages.submaps import Submaps
from roman_sim.runner.taskrunner import TaskRunner

SHORT = ["robots.0.max_length_m=12", "robots.1.max_length_m=12"]


def _stage(name):
    return next(s for s in STAGES if s.name == name)


def test_stage_table_orders_inputs_before_use():
    assert STAGE_NAMES == ("world", "maps", "submaps", "evaluation", "posegraph", "ate", "report")
    for k, stage in enumerate(STAGES):
        assert set(stage.inputs) <= set(STAGE_NAMES[:k]), stage.name
        assert set(stage.required()) <= set(stage.inputs)
    assert _stage("report").required() == ("submaps", "evaluation", "posegraph", "ate")


def test_a_missing_required_input_is_one_clear_error():
    with pytest.raises(ConfigError, match="stage posegraph needs the output of submaps, evaluation"):
        _stage("posegraph").build_inputs({})


def test_evaluation_stage_round_trips_its_output(tmp_path):
    a, b, truth = make_submap_pair(0, n_inliers=10, n_outliers_a=4, n_outliers_b=4, descriptor_dim=16)
    ctx = RunContext(load_scenario("smoke", ["aligners=[roman, clipper]"]), tmp_path)
    stage = EvaluationStage()
    out = stage.run(ctx, EvaluationInputs(Submaps({"a": [a], "b": [b]})), TaskRunner())
    got = [(s.truth.a, s.truth.b, s.method) for s in out.scores]
    assert got == [("a/0", "b/0", "roman"), ("a/0", "b/0", "clipper")]
    roman = next(s for s in out.scores if s.method == "roman")
    assert roman.correct and roman.n_assoc >= 8  # ROMAN finds the planted inliers
    files = stage.save(out, ctx)
    assert {"pairs.csv", "metrics.json", "alignments.json"} <= set(files)
    back = stage.load(ctx, files)
    assert to_json(back.metrics) == to_json(out.metrics)
    assert [to_json(r.row()) for r in back.alignments] == [to_json(r.row()) for r in out.alignments]
    assert back.notes == out.notes and files == ["metrics.json", "pairs.csv", "alignments.json"]
    assert "per_pair_s" in out.timings["alignment"]["roman"]  # runtimes go to the timings only
    assert out.timings["pairs"]["aligned"] == 1 and back.timings == {}
    assert "runtime" not in (tmp_path / "pairs.csv").read_text().splitlines()[0]


def test_downstream_stages_rerun_from_loaded_outputs(smoke_run, tmp_path):
    """Posegraph, ATE and report recomputed from the saved stages give the saved bytes."""
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    ctx = RunContext(smoke_run.scenario, run_dir)
    man = read_manifest(run_dir)
    loaded = {n: _stage(n).load(ctx, man.stages[n].files) for n in ("maps", "submaps", "evaluation")}
    # the report's front-end snapshot renders from the world
    loaded["world"] = _stage("world").run(ctx, NoInputs(), TaskRunner())
    saved = [f for n in ("posegraph", "ate", "report") for f in man.stages[n].files]
    assert {"ate.json", "posegraph.json", "report.md", "map_stats.json", "plots/trajectories.png"} <= set(saved)
    before = {f: (run_dir / f).read_bytes() for f in saved}
    for stage in (PoseGraphStage(), AteStage(), ReportStage()):
        out = stage.run(ctx, stage.build_inputs(loaded), TaskRunner())
        loaded[stage.name] = stage.load(ctx, stage.save(out, ctx))
    assert {f: (run_dir / f).read_bytes() for f in before} == before
    assert loaded["ate"].ate.rmse("roman") == smoke_run.ate.rmse("roman")


def test_keys_follow_the_configuration():
    def keys(sets):
        ctx = RunContext(load_scenario("smoke", sets), None)  # type: ignore[arg-type]
        out: dict[str, str] = {}
        for s in STAGES:
            out[s.name] = s.key(ctx, {i: out.get(i) for i in s.inputs})
        return out

    base, pg = keys([]), keys(["posegraph.lc_sigma_m=3.0"])
    assert [n for n in STAGE_NAMES if base[n] != pg[n]] == ["posegraph", "ate", "report"]
    renamed = keys(["name=smoke_renamed"])
    assert [n for n in STAGE_NAMES if base[n] != renamed[n]] == ["report"]
    other_seed = keys(["seed=4"])
    assert all(base[n] != other_seed[n] for n in STAGE_NAMES)


def test_one_robot_rerun_in_a_two_robot_folder_reads_only_its_robot(smoke_run, tmp_path):
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    robot_a = (
        "robots=[{name: a, path: {kind: road, road_index: 0}, camera: {width: 160, height: 120}, "
        "render_rgb: false, max_length_m: 30}]"
    )
    res = Experiment(load_scenario("smoke", [robot_a]), run_dir).run()
    assert res.map_stats.robots == 1 and res.reused == []
    assert not (run_dir / "maps" / "b.npz").exists() and not (run_dir / "submaps" / "b.npz").exists()
    assert all(
        s.truth.robot_a == s.truth.robot_b == "a"
        for s in EvaluationStage().load(RunContext(res.scenario, run_dir), []).scores
    )
    assert res.map_stats.trajectory_km == pytest.approx(0.03, abs=0.002)
    assert RunResult.load(run_dir).map_stats == res.map_stats


def test_saved_submaps_of_other_robots_are_never_read(smoke_run, tmp_path):
    src = tmp_path / "mine"
    shutil.copytree(smoke_run.run_dir / "submaps", src)
    a, b, _ = make_submap_pair(1, n_inliers=6, n_outliers_a=2, n_outliers_b=2, descriptor_dim=8)
    save_submaps(src / "zz.npz", [b])  # a stale file of a robot the scenario does not have
    res = Experiment(load_scenario("smoke"), tmp_path / "run", submaps_dir=src).run()
    assert res.map_stats.robots == 2
    assert to_json(res.metrics)["n_pairs"] == smoke_run.metrics.n_pairs
    (src / "b.npz").unlink()
    with pytest.raises(ConfigError, match=r"no b.npz .*found: a.npz, zz.npz"):
        Experiment(load_scenario("smoke"), tmp_path / "run2", submaps_dir=src).run()


def test_run_stopped_before_the_report_is_not_complete(smoke_run, tmp_path, monkeypatch):
    from roman_sim.pipeline.sweep import _is_done

    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(ReportStage, "run", boom)
    with pytest.raises(KeyboardInterrupt):
        Experiment(load_scenario("smoke"), run_dir, from_stage="report").run()
    assert (run_dir / "metrics.json").is_file()  # earlier stages' results are kept ...
    with pytest.raises(StorageError, match=r"stages missing: report"):  # ... but never reported as a run
        RunResult.load(run_dir)
    assert not _is_done(run_dir, "smoke", (), 0)
    monkeypatch.undo()
    res = Experiment(load_scenario("smoke"), run_dir).run()
    assert set(res.reused) == {"maps", "submaps", "evaluation", "posegraph", "ate"}
    assert _is_done(run_dir, "smoke", (), 0) and not _is_done(run_dir, "smoke", ("posegraph.lc_sigma_m=3.0",), 0)


def test_edited_config_or_corrupt_manifest(smoke_run, tmp_path):
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    cfg = run_dir / "config.yaml"
    cfg.write_text(cfg.read_text().replace("seed: 0", "seed: 3"))
    with pytest.raises(StorageError, match="config.yaml does not match"):
        RunResult.load(run_dir)
    (run_dir / "manifest.json").write_text("{not json")
    with pytest.raises(StorageError, match="manifest.json: not valid JSON"):
        RunResult.load(run_dir)
    manifest = json.loads((smoke_run.run_dir / "manifest.json").read_text())
    assert manifest["config_hash"] == smoke_run.scenario.config_hash()


def test_no_pipeline_function_receives_the_experiment():
    """Stages and helpers see the run context and their inputs, never the Experiment."""
    import ast
    from pathlib import Path

    import roman_sim.pipeline as pipeline

    for path in Path(pipeline.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for arg in node.args.args + node.args.kwonlyargs:
                    ann = ast.unparse(arg.annotation) if arg.annotation else ""
                    assert "Experiment" not in ann and arg.arg != "exp", f"{path.name}:{node.lineno} {node.name}"
