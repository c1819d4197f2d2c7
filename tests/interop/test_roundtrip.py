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

DENSE = {"families.0.density": 180, "families.1.density": 90, "families.2.density": 120,
         "families.3.density": 90, "families.4.density": 60, "families.5.density": 60}


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
    from roman_sim.mapping.mapper import Mapper
    from roman_sim.mapping.segmenter import build_segmenter
    from roman_sim.mapping.semantics import SimulatedEncoder

    mapper = Mapper(sc.mapping, build_segmenter(sc.frontend.segmenter, seed=sc.seed),
                    SimulatedEncoder(sc.frontend.semantics, seed=sc.seed, families=families, robot=robot), seed=sc.seed)
    for f in frames:
        mapper.process(f)
    return mapper.finish()


def test_imported_sequence_gives_the_same_segment_map(exported) -> None:
    from roman_sim.interop.objects import read_object_table
    from roman_sim.interop.source import scenario_streams

    sc, out = exported
    world, streams = scenario_streams(sc)
    families = {o.id: o.family for o in world.truth.objects}
    assert {r["id"]: r["family"] for r in read_object_table(out)} == families
    total = 0
    for s in streams:
        direct = _map(sc, families, s.name, s.frames())
        imported = _map(sc, families, s.name, read_tum_sequence(out / s.name, robot=s.name).frames())
        assert_same_segment_map(direct, imported)
        total += len(direct)
    assert total >= 5  # the comparison is not vacuous
