"""The cache notices changed defaults and code, and shares stages between run folders.

Runs start from a copy of the session's smoke run, so only what a test changes is computed.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

import roman_sim
from roman_sim.align.aligners import RomanAligner, RomanParams
from roman_sim.core.records import to_json
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stagecache import StageCache

CACHED = ["maps", "submaps", "evaluation", "posegraph", "ate", "report"]


def _copy(run: RunResult, to: Path) -> Path:
    shutil.copytree(run.run_dir, to)
    return to


def _config(run_dir: Path) -> dict:
    return yaml.safe_load((run_dir / "config.yaml").read_text(encoding="utf-8"))


class _FourAssociations(RomanParams):
    """ROMAN's parameters with another default (as if its code had been edited)."""

    min_associations_for_transform: int = 4


def test_a_changed_default_reruns_what_it_affects_and_nothing_else(smoke_run, tmp_path, monkeypatch):
    run_dir = _copy(smoke_run, tmp_path / "run")
    assert _config(run_dir)["aligners"][0]["params"]["min_associations_for_transform"] == 3  # resolved, written
    monkeypatch.setattr(RomanAligner, "params_model", _FourAssociations)
    res = Experiment(load_scenario("smoke"), run_dir, cache=False).run()
    assert res.reused == ["maps", "submaps"]  # the aligners' stage and those after it ran again
    cfg = _config(run_dir)
    assert cfg["aligners"][0]["params"]["min_associations_for_transform"] == 4
    assert cfg["aligners"][1]["params"]["min_associations_for_transform"] == 3  # clipper keeps its own model
    # editing nothing more: every stage is reused
    again = Experiment(load_scenario("smoke"), run_dir, cache=False).run()
    assert again.reused == CACHED
    assert to_json(again.metrics) == to_json(res.metrics)


def test_an_unchanged_run_reuses_every_stage(smoke_run, tmp_path):
    res = Experiment(load_scenario("smoke"), _copy(smoke_run, tmp_path / "run"), cache=False).run()
    assert res.reused == CACHED
    assert to_json(res.metrics) == to_json(smoke_run.metrics)


_KEYS = """
import json, sys
import roman_sim
assert roman_sim.__file__.startswith(sys.argv[1]), roman_sim.__file__
from roman_sim.pipeline.resolve import resolve_scenario
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages import STAGES
ctx = RunContext(resolve_scenario(load_scenario("smoke")), None)

def keys():
    out = {}
    for s in STAGES:
        out[s.name] = s.key(ctx, {i: out.get(i) for i in s.inputs})
    return out

changed = []
for module in sys.argv[2:]:  # edit one module after the other, in the copy
    before = keys()
    with open(f"{sys.argv[1]}/{module}", "a", encoding="utf-8") as fh:
        fh.write("\\n# edited\\n")
    after = keys()
    changed.append(sorted(s for s in before if before[s] != after[s]))
print(json.dumps(changed))
"""


def test_editing_a_module_changes_the_keys_of_the_stages_that_run_it(tmp_path):
    """In a copy of the package: an edit re-keys the stages importing the module and those after them."""
    pkg = tmp_path / "pkg"
    shutil.copytree(Path(roman_sim.__file__).parent, pkg / "roman_sim", ignore=shutil.ignore_patterns("__pycache__"))
    edits = {
        "roman_sim/posegraph/solve.py": ["ate", "posegraph", "report"],
        "roman_sim/align/aligners.py": ["ate", "evaluation", "posegraph", "report"],
        "roman_sim/mapping/submap.py": ["ate", "evaluation", "posegraph", "report", "submaps"],
        "roman_sim/pipeline/stages/maps_job.py": ["ate", "evaluation", "maps", "posegraph", "report", "submaps"],
        "roman_sim/pipeline/stages/maps_robot.py": ["ate", "evaluation", "maps", "posegraph", "report", "submaps"],
        "roman_sim/pipeline/stages/maps_input.py": ["ate", "evaluation", "maps", "posegraph", "report", "submaps"],
        "roman_sim/interop/odometry_in.py": ["ate", "evaluation", "maps", "posegraph", "report", "submaps"],
        "roman_sim/report/markdown.py": ["report"],
        "roman_sim/runner/dask_executor.py": [],  # where tasks run, not what they compute
        "roman_sim/pipeline/resolve.py": [],  # its results are hashed by value
    }
    out = subprocess.run(
        [sys.executable, "-c", _KEYS, str(pkg), *edits],
        env={**os.environ, "PYTHONPATH": str(pkg)},
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=True,
    )
    assert dict(zip(edits, json.loads(out.stdout))) == edits


def _counting(monkeypatch: pytest.MonkeyPatch, calls: list[str], target: str) -> None:
    module, name = target.rsplit(".", 1)
    mod = importlib.import_module(module)
    original = getattr(mod, name)

    def counted(*args, **kwargs):
        calls.append(target)
        return original(*args, **kwargs)

    monkeypatch.setattr(mod, name, counted)


@pytest.fixture(scope="module")
def added_aligner(smoke_run, tmp_path_factory):
    """``roman-sim run smoke --aligner <plug-in>`` into a new folder, the smoke run's stages in the shared cache.

    Returns the new run folder, the cache, and the calls counted during the command.
    """
    from roman_sim.cli import app

    tmp = tmp_path_factory.mktemp("shared")
    cache = StageCache(tmp / "cache")
    seeded = Experiment(load_scenario("smoke"), _copy(smoke_run, tmp / "first"), cache=cache).run()
    assert seeded.reused == CACHED  # its own folder's stages, now stored in the cache too
    calls: list[str] = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ROMAN_SIM_CACHE", str(cache.root))
        for target in (
            "roman_sim.pipeline.stages.maps.map_one",
            "roman_sim.pipeline.stages.maps_robot.map_one",
            "roman_sim.pipeline.plugins.dry_call",
        ):
            _counting(mp, calls, target)
        out = tmp / "second"
        plugin = "roman_sim.examples.mutual_nn_aligner:MutualNNAligner"
        result = CliRunner().invoke(
            app, ["run", "smoke", "--out", str(out), "--aligner", plugin, "--executor", "serial"]
        )
    assert result.exit_code == 0, result.output
    return out, cache, calls


def test_adding_an_aligner_in_another_folder_maps_nothing(added_aligner):
    out, cache, calls = added_aligner
    assert not [c for c in calls if c.endswith("map_one")]  # no robot rendered or mapped
    timings = json.loads((out / "timings.json").read_text())["stages"]
    assert timings["maps"]["reused"] and timings["submaps"]["reused"]
    assert not timings["evaluation"]["reused"]
    manifest = json.loads((out / "manifest.json").read_text())
    entry = next(e for e in cache.entries() if e.parent.name == "maps")
    for f in manifest["stages"]["maps"]["files"]:  # the cache's bytes, copied: no file shared with it
        assert (out / f).read_bytes() == (entry / "files" / f).read_bytes()
        assert os.stat(out / f).st_ino != os.stat(entry / "files" / f).st_ino
        assert manifest["stages"]["maps"]["sha256"][f] == hashlib.sha256((out / f).read_bytes()).hexdigest()
    cfg = _config(out)
    assert cfg["aligners"][-1] == {
        "method": "roman_sim.examples.mutual_nn_aligner:MutualNNAligner",
        "label": None,
        "params": {"min_cosine": 0.9},  # the plug-in's constructor default, resolved
    }


def test_each_plugin_is_dry_called_once_per_run(added_aligner):
    _, _, calls = added_aligner
    assert calls.count("roman_sim.pipeline.plugins.dry_call") == 1  # the CLI validates, the run does not again


def _stage_files(run: Path) -> dict[str, str]:
    """Two files of a made-up stage in ``run``: path -> SHA-256."""
    (run / "maps").mkdir(parents=True)
    (run / "maps" / "a.npz").write_bytes(b"a" * 100)
    (run / "notes.json").write_text("{}")
    return {f: hashlib.sha256((run / f).read_bytes()).hexdigest() for f in ("maps/a.npz", "notes.json")}


def test_cache_entries_are_complete_or_absent(tmp_path):
    run = tmp_path / "run"
    files = _stage_files(run)
    cache = StageCache(tmp_path / "cache")
    threads = [threading.Thread(target=cache.publish, args=("maps", "k1", run, files)) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert cache.entries() == [cache.entry_dir("maps", "k1")]  # one entry, no leftovers
    assert not list((tmp_path / "cache" / "stages" / "maps").glob(".*"))
    other = tmp_path / "other"
    assert cache.fetch("maps", "k1", other) == files
    assert (other / "maps" / "a.npz").read_bytes() == b"a" * 100
    assert cache.fetch("maps", "k2", other) is None
    (cache.entry_dir("maps", "k1") / "files" / "notes.json").unlink()  # a lost file invalidates the entry
    assert cache.fetch("maps", "k1", tmp_path / "third") is None
    assert not (tmp_path / "third").exists()
    assert cache.entries() == []  # dropped
    cache.publish("maps", "k1", run, files)  # republished whole
    assert cache.fetch("maps", "k1", tmp_path / "third") == files
    assert cache.clear() == 1 and cache.entries() == []


def test_a_file_changed_before_publishing_is_not_stored(tmp_path, caplog):
    run = tmp_path / "run"
    files = _stage_files(run)
    (run / "maps" / "a.npz").write_bytes(b"b" * 100)  # same size, other bytes than the run recorded
    cache = StageCache(tmp_path / "cache")
    with caplog.at_level("WARNING", logger="roman_sim.pipeline.stagecache"):
        cache.publish("maps", "k1", run, files)
    assert cache.entries() == [] and not list((tmp_path / "cache").rglob("*.npz"))
    assert [r.getMessage() for r in caplog.records] == [
        f"shared cache: {run / 'maps' / 'a.npz'} changed since the run wrote it; stage maps not stored"
    ]


@pytest.mark.parametrize("damage", ["flip", "truncate", "entry"])
def test_a_damaged_entry_is_dropped_with_one_warning_naming_the_file(tmp_path, caplog, damage):
    run = tmp_path / "run"
    files = _stage_files(run)
    cache = StageCache(tmp_path / "cache")
    cache.publish("maps", "k1", run, files)
    stored = cache.entry_dir("maps", "k1") / "files" / "maps" / "a.npz"
    if damage == "flip":  # one byte changed in place, the size kept
        with stored.open("r+b") as fh:
            fh.seek(50)
            fh.write(b"x")
    elif damage == "truncate":
        stored.write_bytes(b"a" * 99)
    else:
        (cache.entry_dir("maps", "k1") / "entry.json").write_text("{")
    with caplog.at_level("WARNING", logger="roman_sim.pipeline.stagecache"):
        assert cache.fetch("maps", "k1", tmp_path / "other") is None
    warned = [r.getMessage() for r in caplog.records]
    assert len(warned) == 1 and warned[0].startswith("shared cache: entry dropped, ")
    assert (str(stored) if damage != "entry" else str(cache.entry_dir("maps", "k1"))) in warned[0]
    assert cache.entries() == [] and not (tmp_path / "other" / "maps" / "a.npz").exists()
    assert cache.lookup("maps", "k1") is None


def test_cache_verify_names_and_drops_damaged_entries(tmp_path, monkeypatch):
    from roman_sim.cli import app

    run = tmp_path / "run"
    files = _stage_files(run)
    cache = StageCache(tmp_path / "cache")
    for key in ("k1", "k2"):
        cache.publish("maps", key, run, files)
    (cache.entry_dir("maps", "k2") / "files" / "notes.json").write_text("{ }")
    monkeypatch.setenv("ROMAN_SIM_CACHE", str(cache.root))
    res = CliRunner().invoke(app, ["cache", "--verify"])
    assert res.exit_code == 1
    assert f"dropped: {cache.entry_dir('maps', 'k2') / 'files' / 'notes.json'}: " in res.stdout
    assert "1 entries verified, 1 dropped" in res.stdout
    again = CliRunner().invoke(app, ["cache", "--verify"])
    assert again.exit_code == 0 and "1 entries verified, 0 dropped" in again.stdout


def test_a_cache_path_that_is_a_file_is_named_once(tmp_path, monkeypatch, caplog):
    from roman_sim.cli import app
    from roman_sim.pipeline import stagecache

    where = tmp_path / "cachefile"
    where.write_text("not a folder")
    monkeypatch.setenv("ROMAN_SIM_CACHE", str(where))
    monkeypatch.setattr(stagecache, "_warned_not_a_folder", set())
    with caplog.at_level("WARNING", logger="roman_sim.pipeline.stagecache"):
        assert StageCache.default() is None and StageCache.default() is None
    assert [r.getMessage() for r in caplog.records] == [
        f"shared stage cache off: {where} is a file, not a folder (set $ROMAN_SIM_CACHE to a folder, or to off)"
    ]
    res = CliRunner().invoke(app, ["cache"])
    assert res.exit_code == 0 and f"the shared stage cache is off: {where} is a file, not a folder" in res.stdout
    monkeypatch.setenv("ROMAN_SIM_CACHE", str(where / "below"))
    assert StageCache.default() is None


def test_the_cache_folder_and_switching_it_off(monkeypatch, tmp_path):
    from roman_sim.pipeline.stagecache import default_cache_dir

    monkeypatch.setenv("ROMAN_SIM_CACHE", str(tmp_path / "c"))
    assert default_cache_dir() == tmp_path / "c"
    monkeypatch.setenv("ROMAN_SIM_CACHE", "off")
    assert default_cache_dir() is None and StageCache.default() is None
    monkeypatch.delenv("ROMAN_SIM_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "xdg" / "roman_sim"


def test_every_run_command_declares_the_same_executor_options():
    import typer.main

    from roman_sim.cli import _executor as X
    from roman_sim.cli import app

    group = typer.main.get_command(app)
    declared = {name: option.help for name, (_, option) in X._OPTIONS.items()}
    for name in ("run", "demo", "sweep", "reproduce", "benchmark"):
        params = {p.name: getattr(p, "help", None) for p in group.commands[name].params}  # type: ignore[attr-defined]
        assert {k: params.get(k) for k in declared} == declared, name


def test_a_sweep_runs_a_finished_cell_again_when_the_code_of_a_stage_changes(smoke_run, tmp_path, monkeypatch):
    """A sweep's cell is done only while every stage's key holds: resolved parameters and code."""
    from roman_sim.pipeline.stages.evaluation import EvaluationStage
    from roman_sim.pipeline.sweep import _is_done

    run_dir = _copy(smoke_run, tmp_path / "run")
    assert _is_done(run_dir, "smoke", (), 0)  # nothing changed: reused
    original = EvaluationStage.code_fingerprint
    monkeypatch.setattr(EvaluationStage, "code_fingerprint", lambda self, ctx: original(self, ctx) + "-edited")
    assert not _is_done(run_dir, "smoke", (), 0)  # the evaluation's code changed (its fingerprint)
    monkeypatch.undo()
    monkeypatch.setattr(RomanAligner, "params_model", _FourAssociations)
    assert not _is_done(run_dir, "smoke", (), 0)  # a default of an aligner the cell runs changed
