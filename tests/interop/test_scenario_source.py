"""Scenarios whose robots read TUM folders (``roman_sim.interop.tum_reader``): path resolution, caching, and bad
input in one line."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from roman_sim.core.errors import ConfigError
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario


def _write(path: Path, robots: list[dict], **extra: object) -> Path:
    doc = {"name": "from_tum", "robots": robots, "frontend": {"segmenter": "perfect"}, **extra}
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.fixture
def folder(tum_export: Path, tmp_path: Path) -> Path:
    """A private copy of the export (robot a's folder and the object table), next to a scenario file."""
    dst = tmp_path / "data"
    shutil.copytree(tum_export / "a", dst / "a")
    shutil.copy(tum_export / "objects.json", dst / "objects.json")
    return dst


def test_relative_folder_resolves_next_to_the_scenario_and_maps_are_cached(folder: Path, tmp_path: Path) -> None:
    sc_file = _write(tmp_path / "sc.yaml", [{"name": "a", "source": {"tum": "data/a"}}])
    sc = load_scenario(sc_file)
    assert sc.robots[0].source.tum == (folder / "a").resolve() and not sc.needs_world
    first = Experiment(sc, tmp_path / "run").run()
    config = yaml.safe_load((tmp_path / "run" / "config.yaml").read_text())
    assert config["robots"][0]["source"]["tum"] == str((folder / "a").resolve())
    assert first.map_stats.segments is not None and first.map_stats.segments > 0
    assert "maps" in Experiment(load_scenario(sc_file), tmp_path / "run").run().reused
    with (folder / "a" / "depth.txt").open("a") as fh:  # the sequence changed: it is mapped again
        fh.write("# edited\n")
    assert "maps" not in Experiment(load_scenario(sc_file), tmp_path / "run").run().reused


def test_bad_sources_fail_before_any_work(folder: Path, tmp_path: Path) -> None:
    cases = [
        ([{"name": "a", "source": {"tum": "nowhere"}}], {}, "not a folder"),
        ([{"name": "a", "source": {"tum": str(folder / "a"), "depth_scael": 1}}], {}, "unknown key"),
        (
            [
                {"name": "a", "source": {"tum": str(folder / "a")}},
                {"name": "b", "path": {"kind": "reverse_of", "of": "a"}},
            ],
            {"world": {"preset": "tiny"}},
            "robots.1.path.of",
        ),
    ]
    for robots, extra, message in cases:
        with pytest.raises(ConfigError, match=message):
            Experiment(load_scenario(_write(tmp_path / "bad.yaml", robots, **extra)), tmp_path / "bad").validate()
    (folder / "groundtruth.txt").write_text("")  # not the sequence's own: it reads a/groundtruth.txt
    (folder / "a" / "groundtruth.txt").unlink()
    with pytest.raises(ConfigError, match="no groundtruth.txt"):
        Experiment(
            load_scenario(_write(tmp_path / "g.yaml", [{"name": "a", "source": {"tum": "data/a"}}])), tmp_path / "g"
        ).validate()


def test_simulated_encoder_needs_the_object_table(folder: Path, tmp_path: Path) -> None:
    (folder / "objects.json").unlink()
    sc = load_scenario(_write(tmp_path / "sc.yaml", [{"name": "a", "source": {"tum": "data/a"}}]))
    with pytest.raises(ConfigError, match="objects.json"):
        Experiment(sc, tmp_path / "run").validate()


def test_cli_run_and_export_name_the_problem(folder: Path, tmp_path: Path, run_cli) -> None:
    sc_file = _write(tmp_path / "sc.yaml", [{"name": "a", "source": {"tum": "missing/a"}}])
    code, _, err = run_cli("run", str(sc_file), "--out", str(tmp_path / "run"))
    assert code == 1 and "not a folder" in err and len(err.strip().splitlines()) == 1
    sc_file = _write(tmp_path / "sc2.yaml", [{"name": "a", "source": {"tum": "data/a"}}])
    code, _, err = run_cli("export", str(sc_file), "--format", "tum", "--out", str(tmp_path / "x"))
    assert code == 1 and "no simulated robot" in err and "read from recorded sequences: a" in err
