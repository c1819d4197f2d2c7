"""The cache's fault cases on a real run: a damaged entry, an edited run folder, an edited helper module.

Each case ends either in a recomputed, correct result (equal to the clean run's) or in one
warning line naming the file, never in a silently wrong result.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import sys
import textwrap
from pathlib import Path

import pytest
from typer.testing import CliRunner

from roman_sim.core.records import to_json
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stagecache import StageCache

CACHED = ["maps", "submaps", "evaluation", "posegraph", "ate", "report"]


def _flip(path: Path, at: int = 40) -> None:
    """Change one byte of ``path`` in place (its size kept), as a bad disk or an editor would."""
    with path.open("r+b") as fh:
        fh.seek(at)
        old = fh.read(1)
        fh.seek(at)
        fh.write(bytes([old[0] ^ 0x01]))


def _files(run_dir: Path) -> dict[str, bytes]:
    man = json.loads((run_dir / "manifest.json").read_text())
    return {f: (run_dir / f).read_bytes() for rec in man["stages"].values() for f in rec["files"]}


def _one_digit_more(path: Path) -> None:
    """Add one to the first ``n_pairs`` figure of a JSON file (valid JSON, one figure wrong)."""
    text = path.read_text()
    path.write_text(re.sub(r'("n_pairs":\s*)(\d+)', lambda m: m[1] + str(int(m[2]) + 1), text, count=1))
    assert path.read_text() != text


def _warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]


@pytest.fixture(scope="module")
def seeded(smoke_run, tmp_path_factory):
    """A cache holding the smoke run's stages (published from a copy of its folder)."""
    tmp = tmp_path_factory.mktemp("faults")
    cache = StageCache(tmp / "cache")
    first = tmp / "first"
    shutil.copytree(smoke_run.run_dir, first)
    assert Experiment(load_scenario("smoke"), first, cache=cache).run().reused == CACHED
    return cache, first


def _copy_cache(cache: StageCache, to: Path) -> StageCache:
    shutil.copytree(cache.root, to)
    return StageCache(to)


def test_a_run_taken_whole_from_the_cache_equals_the_run_computed_fresh(smoke_run, seeded, tmp_path):
    cache, _ = seeded
    out = tmp_path / "from_cache"
    res = Experiment(load_scenario("smoke"), out, cache=cache).run()
    assert res.reused == CACHED
    assert _files(out) == _files(smoke_run.run_dir)
    # the manifest too: files listed in the order the stages wrote them, whatever path a stage took
    assert (out / "manifest.json").read_bytes() == (smoke_run.run_dir / "manifest.json").read_bytes()


def test_damaged_cache_entries_are_dropped_and_computed_again(smoke_run, seeded, tmp_path, caplog):
    cache = _copy_cache(seeded[0], tmp_path / "cache")
    n_entries = len(cache.entries())  # the stages and each aligner's results
    damaged = {}
    for stage, name in [
        ("maps", "maps/a.npz"),
        ("submaps", "submaps/b.npz"),
        ("evaluation", "pairs.csv"),
        ("ate", "ate.json"),
    ]:
        (entry,) = [e for e in cache.entries() if e.parent.name == stage]
        _flip(entry / "files" / name, at=(entry / "files" / name).stat().st_size // 2)
        damaged[stage] = entry / "files" / name
    out = tmp_path / "run"
    with caplog.at_level("WARNING"):
        res = Experiment(load_scenario("smoke"), out, cache=cache).run()
    warned = _warnings(caplog)
    assert len(warned) == len(damaged), warned  # one line per damaged entry, naming the file
    for path in damaged.values():
        assert sum(str(path) in w for w in warned) == 1
    assert "maps" not in res.reused and "ate" not in res.reused
    assert _files(out) == _files(smoke_run.run_dir)  # recomputed: the clean run's bytes
    assert cache.verify() == (n_entries, [])  # the recomputed stages were published again


def test_a_damaged_metrics_file_in_the_cache_is_caught(smoke_run, seeded, tmp_path, caplog):
    cache = _copy_cache(seeded[0], tmp_path / "cache")
    (entry,) = [e for e in cache.entries() if e.parent.name == "evaluation"]
    metrics = entry / "files" / "metrics.json"
    _one_digit_more(metrics)
    with caplog.at_level("WARNING"):
        res = Experiment(load_scenario("smoke"), tmp_path / "run", cache=cache).run()
    assert len(_warnings(caplog)) == 1 and str(metrics) in _warnings(caplog)[0]
    assert to_json(res.metrics) == to_json(smoke_run.metrics)


def test_an_in_place_edit_of_a_run_folder_reaches_neither_the_cache_nor_another_run(smoke_run, seeded, tmp_path):
    cache, first = seeded
    cache = _copy_cache(cache, tmp_path / "cache")
    folder = tmp_path / "edited"
    shutil.copytree(first, folder)
    Experiment(load_scenario("smoke"), folder, cache=cache).run()
    _flip(folder / "ate.json")  # edited in place: no new file, the same inode
    other = tmp_path / "other"
    Experiment(load_scenario("smoke"), other, cache=cache).run()
    assert (other / "ate.json").read_bytes() == (smoke_run.run_dir / "ate.json").read_bytes()


def test_an_edited_run_file_is_computed_again_with_one_warning(smoke_run, tmp_path, caplog):
    folder = tmp_path / "run"
    shutil.copytree(smoke_run.run_dir, folder)
    _flip(folder / "ate.json")
    with caplog.at_level("WARNING"):
        res = Experiment(load_scenario("smoke"), folder, cache=False).run()
    warned = _warnings(caplog)
    assert (
        len(warned) == 1 and str(folder / "ate.json") in warned[0] and "changed after the stage wrote it" in warned[0]
    )
    assert "ate" not in res.reused and "maps" in res.reused
    assert (folder / "ate.json").read_bytes() == (smoke_run.run_dir / "ate.json").read_bytes()


def test_report_names_a_file_edited_after_the_run(smoke_run, tmp_path, caplog):
    from roman_sim.cli import app

    folder = tmp_path / "run"
    shutil.copytree(smoke_run.run_dir, folder)
    metrics = folder / "metrics.json"
    _one_digit_more(metrics)
    with caplog.at_level("WARNING"):
        RunResult.load(folder)
    assert [w for w in _warnings(caplog) if str(metrics) in w]
    res = CliRunner().invoke(app, ["report", str(folder), "--verify"], env={"COLUMNS": "400"})
    assert res.exit_code == 1 and f"{metrics} changed after the run wrote it" in res.stdout


def test_every_file_of_a_run_has_its_sha256_in_the_manifest(smoke_run):
    man = json.loads((smoke_run.run_dir / "manifest.json").read_text())
    timed = []
    for rec in man["stages"].values():  # wall-clock times differ between two runs: no hash for them
        assert sorted(rec["sha256"]) == sorted(f for f in rec["files"] if not f.endswith(".times.json"))
        timed += [f for f in rec["files"] if f not in rec["sha256"]]
    assert timed == ["aligned/roman.times.json", "aligned/clipper.times.json"]
    for rec in man["stages"].values():
        for f, sha in rec["sha256"].items():
            assert hashlib.sha256((smoke_run.run_dir / f).read_bytes()).hexdigest() == sha


PLUGIN = """
from roman_sim.examples.mutual_nn_aligner import MutualNNAligner
import {helper}


class HelperAligner(MutualNNAligner):
    name = "HelperAligner"

    def align(self, a, b):
        return {helper}.passed(super().align(a, b))
"""

HELPER = """
def passed(result):
    return result
"""


def test_editing_a_plugins_helper_module_runs_its_stage_again(smoke_run, tmp_path, monkeypatch):
    """The helper is a module of its own beside the plug-in, not part of the plug-in's package."""
    where = tmp_path / "mine"
    where.mkdir()
    (where / "myplugin.py").write_text(textwrap.dedent(PLUGIN.format(helper="myhelper")))
    (where / "myhelper.py").write_text(textwrap.dedent(HELPER))
    monkeypatch.syspath_prepend(str(where))
    folder = tmp_path / "run"
    shutil.copytree(smoke_run.run_dir, folder)
    cache = StageCache(tmp_path / "cache")
    sc = load_scenario("smoke", aligners=["myplugin:HelperAligner"])
    first = Experiment(sc, folder, cache=cache).run()
    assert "evaluation" not in first.reused and "maps" in first.reused
    again = Experiment(sc, folder, cache=cache).run()
    assert again.reused == CACHED
    with (where / "myhelper.py").open("a") as fh:  # the helper edited; the plug-in's own file not
        fh.write("\n# a comment is an edit too\n")
    edited = Experiment(sc, folder, cache=cache).run()
    assert "evaluation" not in edited.reused and "maps" in edited.reused
    other = Experiment(sc, tmp_path / "other", cache=cache).run()  # the cache holds the edited code's stage
    assert "evaluation" in other.reused
    for name in ("myplugin", "myhelper"):
        sys.modules.pop(name, None)
