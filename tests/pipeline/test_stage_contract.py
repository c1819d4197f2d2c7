"""The stage contract: ``run`` computes and writes nothing, ``save`` writes; a renamed scenario rewrites the report."""

from __future__ import annotations

import ast
import hashlib
import shutil
from pathlib import Path

import pytest

import roman_sim.pipeline.stages as stages_pkg
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages import STAGES

#: Calls that write, move or delete files: the project's writers and the standard library's.
WRITERS = {
    "atomic_open",
    "write_bytes",
    "write_text",
    "write_json",
    "write_npz",
    "write_arrays",
    "write_with",
    "write_tum",
    "write_evaluation",
    "write_pairs_csv",
    "write_metrics_json",
    "write_report",
    "write_metric_plots",
    "write_map_view",
    "write_recording",
    "write_notes",
    "save_segment_map",
    "save_submaps",
    "save_keyframes",
    "save_per_robot",
    "save_figure",
    "remove_figure",
    "draw_examples",
    "plot_masks",
    "plot_frontend_grades",
    "plot_trajectories",
    "savefig",
    "imsave",
    "save",
    "savez",
    "savez_compressed",
    "tofile",
    "mkdir",
    "makedirs",
    "unlink",
    "remove",
    "rmdir",
    "rmtree",
    "touch",
    "copyfile",
    "copytree",
}


def _called(node: ast.Call) -> str | None:
    f = node.func
    return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None


def _writes(node: ast.Call) -> bool:
    name = _called(node)
    if name in WRITERS or (name or "").startswith(("write_", "save_")):
        return True
    if name == "open":  # open(path, mode) with a mode that writes
        mode = node.args[1] if len(node.args) > 1 else next((k.value for k in node.keywords if k.arg == "mode"), None)
        if mode is None:
            return False  # "r"
        return not isinstance(mode, ast.Constant) or any(c in str(mode.value) for c in "wax+")
    return False


def _writes_outside_save(tree: ast.Module) -> list[str]:
    """``function: call`` for every writing call not inside a ``save`` method."""
    found: list[str] = []

    def visit(node: ast.AST, where: str | None) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if child.name == "save" and isinstance(node, ast.ClassDef):
                    continue  # the one place a stage writes
                visit(child, child.name)
            elif isinstance(child, ast.Call) and _writes(child):
                found.append(f"{where or '<module>'}: {_called(child)}")
                visit(child, where)
            else:
                visit(child, where)

    visit(tree, None)
    return found


def test_the_static_check_finds_writes():
    src = (
        "def run(ctx):\n    write_json(ctx.run_dir / 'x.json', {})\n"
        "def helper(p):\n    open(p, 'w').write('x')\n    p.mkdir()\n"
        "class S:\n    def save(self, out, ctx):\n        write_json(ctx.run_dir / 'x', {})\n"
        "    def load(self, ctx, files):\n        return open(ctx.run_dir / 'x').read()\n"
    )
    assert _writes_outside_save(ast.parse(src)) == ["run: write_json", "helper: open", "helper: mkdir"]


#: The writes of the maps stage's worker job, outside the stage's files: a finished robot's checkpoint (its codec's
#: ``write``, under ``partial/``) and the frame recording kept as a cache (``record_frames``, ``recordings/``).
WORKER_JOB_WRITES = {
    "maps_robot.py": [f"write: {w}" for w in ("save_segment_map", "save_keyframes", "write_arrays", "save_snapshot")],
    "maps_input.py": ["_recording: write_recording"],
}


def test_no_stage_function_writes_outside_save():
    folder = Path(stages_pkg.__file__).parent
    found = {
        path.name: bad
        for path in sorted(folder.glob("*.py"))
        if (bad := _writes_outside_save(ast.parse(path.read_text(encoding="utf-8"))))
    }
    assert found == WORKER_JOB_WRITES


def _digest(run_dir: Path) -> dict[str, str]:
    return {
        p.relative_to(run_dir).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in run_dir.rglob("*")
        if p.is_file()
    }


SHORT = ["robots.0.max_length_m=12", "robots.1.max_length_m=12"]


def test_run_writes_nothing_but_checkpoints(tmp_path, monkeypatch):
    """Each stage's ``run`` in a real experiment: the folder changes only under ``partial/<stage>/``."""
    run_dir = tmp_path / "run"
    changed: dict[str, list[str]] = {}
    for stage in STAGES:
        real = type(stage).run

        def watched(self, ctx, inputs, tasks, _real=real):
            before = _digest(ctx.run_dir)
            out = _real(self, ctx, inputs, tasks)
            after = _digest(ctx.run_dir)
            changed[self.name] = sorted(f for f in after if before.get(f) != after[f]) + sorted(
                f for f in before if f not in after
            )
            return out

        monkeypatch.setattr(type(stage), "run", watched)
    res = Experiment(load_scenario("smoke", SHORT), run_dir).run()
    assert list(changed) == ["world", "maps", "submaps", "evaluation", "posegraph", "ate", "report"]
    assert {s: [f for f in files if not f.startswith(f"partial/{s}/")] for s, files in changed.items()} == {
        s: [] for s in changed
    }
    assert [f for f in changed["maps"] if f.endswith(".json")] == ["partial/maps/a.json", "partial/maps/b.json"]
    assert any(f.startswith("partial/evaluation/") for f in changed["evaluation"])
    assert not (run_dir / "partial").exists() and res.metrics.n_pairs > 0  # checkpoints removed at the end


def test_a_renamed_scenario_rewrites_the_report(smoke_run, tmp_path):
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    before = _digest(run_dir)
    res = Experiment(load_scenario("smoke", ["name=smoke_renamed"]), run_dir).run()
    assert set(res.reused) == {"maps", "submaps", "evaluation", "posegraph", "ate"}
    text = (run_dir / "report.md").read_text(encoding="utf-8")
    assert text.startswith("# Evaluation report: smoke_renamed\n")
    after = _digest(run_dir)
    differ = sorted(f for f in after if before.get(f) != after[f])
    # the report's files (its title, the map view's and the trajectory plot's titles) and the run's records
    want = ["config.yaml", "manifest.json", "plots/map_view.pdf", "plots/map_view.png", "plots/trajectories.pdf"]
    want += ["plots/trajectories.png", "report.md", "timings.json"]
    assert differ == want


@pytest.mark.parametrize("stage", STAGES, ids=lambda s: s.name)
def test_inputs_are_a_dataclass_of_earlier_outputs(stage):
    import dataclasses
    import typing

    hints = typing.get_type_hints(stage.input_type)
    assert dataclasses.is_dataclass(stage.input_type)
    names = [s.name for s in STAGES]
    outputs = {s.name: typing.get_type_hints(type(s).run)["return"] for s in STAGES}
    for field in dataclasses.fields(stage.input_type):
        assert names.index(field.name) < names.index(stage.name), field.name
        assert field.name in stage.required() or field.default is None
        # the field is typed with the output of the stage it is named after
        assert typing.get_args(hints[field.name]) in ((), (outputs[field.name], type(None))), hints[field.name]
        assert outputs[field.name] in (hints[field.name], *typing.get_args(hints[field.name])), hints[field.name]


def test_a_folder_without_the_ate_stage_says_so_and_a_rerun_updates_it(smoke_run, tmp_path):
    import json

    from roman_sim.core.errors import StorageError
    from roman_sim.pipeline.result import RunResult

    run_dir = tmp_path / "old"
    shutil.copytree(smoke_run.run_dir, run_dir)
    man = json.loads((run_dir / "manifest.json").read_text())
    del man["stages"]["ate"]
    man["expected"].remove("ate")
    (run_dir / "manifest.json").write_text(json.dumps(man))
    with pytest.raises(StorageError, match=r"older version without the ate stage\(s\); run it again"):
        RunResult.load(run_dir)
    res = Experiment(load_scenario("smoke"), run_dir).run()
    assert "ate" not in res.reused and {"maps", "submaps", "evaluation", "posegraph"} <= set(res.reused)
    assert RunResult.load(run_dir).ate.rmse("roman") == smoke_run.ate.rmse("roman")
