"""Round trip: export a small scenario as TUM RGB-D, import it, map it: the same segment map.

Tolerance. The imported frames carry the exported instance masks as truth ids (exact), the
RGB (exact) and the odometry and truth poses (9 decimals: 1e-9). Depth comes back within
half a PNG unit, 0.5 / 5000 m = 1e-4 m (here within one float32 step, since the simulated
depth is already quantised to 1 mm), so a back-projected point moves by at most about
1e-4 m * (1 + |u - cx| / fx + |v - cy| / fy) < 3e-4 m. Voxel downsampling (5 cm) can then
move a point that lies that close to a voxel face into the next voxel: a segment may gain
or lose a point or two, and its centre moves by about a voxel over its point count. The
test allows 2 points or 0.5 % per segment, 2 mm per centre; everything discrete (segment
ids, sightings, first / last seen, true-id counts) must be identical.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.interop.tum_reader import read_tum_sequence
from roman_sim.pipeline.scenario import Scenario

from .conftest import TINY

DENSE = {
    "families.0.density": 180,
    "families.1.density": 90,
    "families.2.density": 120,
    "families.3.density": 90,
    "families.4.density": 60,
    "families.5.density": 60,
}


def roundtrip_scenario() -> Scenario:
    """The tiny world at smoke density; both robots 8 s at 160 x 120, the perfect segmenter."""
    data = copy.deepcopy(TINY)
    data["name"] = "roundtrip"
    data["world"]["overrides"] = dict(DENSE)
    for robot in data["robots"]:
        robot.update(camera={"width": 160, "height": 120}, max_duration_s=8.0)
        robot.pop("render_rgb", None)
    return validate_model(Scenario, data, source="roundtrip")


def assert_same_segment_map(direct, imported) -> None:
    """The comparison stated in the module docstring."""
    assert [s.id for s in imported.segments] == [s.id for s in direct.segments]
    np.testing.assert_allclose(imported.times, direct.times, atol=1e-9)
    np.testing.assert_allclose(imported.T_odom_body, direct.T_odom_body, atol=1e-6)
    np.testing.assert_allclose(imported.T_world_body, direct.T_world_body, atol=1e-6)
    for a, b in zip(direct.segments, imported.segments):
        assert (b.num_sightings, b.status) == (a.num_sightings, a.status)
        assert abs(b.first_seen - a.first_seen) < 1e-6 and abs(b.last_seen - a.last_seen) < 1e-6
        assert b.truth_counts == a.truth_counts
        assert abs(len(b.points) - len(a.points)) <= max(2, 0.005 * len(a.points))
        assert np.abs(b.center - a.center).max() <= 2e-3
        if a.descriptor_sum is not None:
            np.testing.assert_allclose(b.descriptor_sum, a.descriptor_sum, atol=1e-4)


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Scenario, Path]:
    from roman_sim.interop import export_scenario

    sc = roundtrip_scenario()
    out = tmp_path_factory.mktemp("roundtrip") / "tum"
    export_scenario(sc, "tum", out)
    return sc, out


def _map(sc: Scenario, families: dict[int, str], robot: str, frames) -> object:
    from roman_sim.frontend.components import build_segmenter
    from roman_sim.frontend.semantics import SimulatedEncoder
    from roman_sim.mapping.mapper import Mapper

    mapper = Mapper(
        sc.mapping,
        build_segmenter(sc.frontend.segmenter, seed=sc.seed),
        SimulatedEncoder(sc.frontend.semantics, seed=sc.seed, families=families, robot=robot),
        seed=sc.seed,
    )
    for f in frames:
        mapper.process(f)
    return mapper.finish()


def test_imported_sequence_gives_the_same_segment_map(exported) -> None:
    from roman_sim.interop.objects import read_object_table
    from roman_sim.interop.source import scenario_streams

    sc, out = exported
    world, streams = scenario_streams(sc)
    families = {o.id: o.family for o in world.truth.objects}
    assert {r.id: r.family for r in read_object_table(out)} == families
    total = 0
    for s in streams:
        direct = _map(sc, families, s.name, s.frames())
        imported = _map(sc, families, s.name, read_tum_sequence(out / s.name, robot=s.name).frames())
        assert_same_segment_map(direct, imported)
        total += len(direct)
    assert total >= 5  # the comparison is not vacuous


def _from_folders(sc: Scenario, out: Path, name: str, **source: object) -> Scenario:
    data = sc.model_dump(mode="json")
    data["name"] = name
    data["robots"] = [{"name": r.name, "source": {"tum": str(out / r.name), **source}} for r in sc.robots]
    return validate_model(Scenario, data, source=name)


@pytest.fixture(scope="module")
def runs(exported, tmp_path_factory: pytest.TempPathFactory):
    """The scenario run directly, and run again from its exported TUM folders."""
    from roman_sim.pipeline.experiment import Experiment

    sc, out = exported
    tmp = tmp_path_factory.mktemp("runs")
    direct = Experiment(sc, tmp / "direct").run()
    return direct, Experiment(_from_folders(sc, out, "roundtrip_tum"), tmp / "imported").run()


def test_pipeline_on_imported_folders_matches_the_direct_run(exported, runs) -> None:
    import csv
    import json

    from roman_sim.mapping.io import load_segment_map, load_submaps

    sc, _ = exported
    direct, imported = runs
    assert "world" not in json.loads((imported.run_dir / "timings.json").read_text())["stages"]
    for r in sc.robots:
        assert_same_segment_map(
            load_segment_map(direct.run_dir / "maps" / f"{r.name}.npz"),
            load_segment_map(imported.run_dir / "maps" / f"{r.name}.npz"),
        )
        a = load_submaps(direct.run_dir / "submaps" / f"{r.name}.npz")
        b = load_submaps(imported.run_dir / "submaps" / f"{r.name}.npz")
        assert [s.name for s in b] == [s.name for s in a] and [len(s) for s in b] == [len(s) for s in a]
        for x, y in zip(a, b):
            np.testing.assert_allclose(y.truth.T_world_submap, x.truth.T_world_submap, atol=1e-6)
            np.testing.assert_array_equal(y.truth.object_ids, x.truth.object_ids)
    assert imported.map_stats.segments == direct.map_stats.segments
    pairs = {}
    for run in (direct, imported):
        with (run.run_dir / "pairs.csv").open() as fh:
            pairs[run.scenario.name] = [
                (r["a"], r["b"], r["method"], r["relevant"], round(float(r["center_dist_m"]), 4))
                for r in csv.DictReader(fh)
            ]
    assert pairs["roundtrip_tum"] == pairs["roundtrip"] and pairs["roundtrip"]
    assert imported.recall("roman") == direct.recall("roman")


def test_pipeline_on_a_sequence_without_instance_labels(exported, tmp_path: Path) -> None:
    """A real sequence has poses but no masks: a truth-free front end maps it, pairs are scored by pose."""
    import csv

    from roman_sim.pipeline.experiment import Experiment

    sc, out = exported
    real = _from_folders(sc, out, "real_like", masks=False)
    real.frontend.segmenter = "roman_sim.examples.depth_segmenter:DepthEdgeSegmenter"
    real.frontend.encoder = "roman_sim.examples.depth_segmenter:ShapeEncoder"
    res = Experiment(real, tmp_path / "real").run()
    rows = list(csv.DictReader((tmp_path / "real" / "pairs.csv").open()))
    assert rows and all(r["overlap"] == "" for r in rows)  # undefined without object ids
    assert all(r["true_x_m"] != "" and r["relevant"] in ("true", "false") for r in rows)
    assert res.map_stats.segments > 0
    assert res.ate.rmse("odometry") is not None  # scored against the sequences' ground truth


def test_view_of_a_run_from_tum_folders(exported, runs, tmp_path: Path) -> None:
    from roman_sim.interop.objects import read_object_table
    from roman_sim.viz import recording_contents, write_run_view

    _, out = exported
    _, imported = runs
    res = write_run_view(imported.run_dir, tmp_path / "v.rrd", max_images=3)
    contents = recording_contents(res.path)
    assert "/world/terrain" not in contents  # no world was generated
    assert contents["/world/objects"]["Boxes3D:centers"] == [len(read_object_table(out))]
    assert res.images == {"a": 3, "b": 3}
    assert len(contents["/world/robots/a/camera/mask"]["SegmentationImage:buffer"]) == 3
