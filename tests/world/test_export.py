"""World folders: plain-MuJoCo reload, truth round trip, corrupt folders."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from roman_sim.core.errors import WorldError
from roman_sim.world import World, export_world, load_world


def test_export_reloads_in_plain_mujoco(tiny_world: World, tmp_path) -> None:
    xml = export_world(tiny_world, tmp_path / "w")
    assert (tmp_path / "w" / "meshes").is_dir() and (tmp_path / "w" / "spec.yaml").is_file()
    m = mujoco.MjModel.from_xml_path(str(xml))
    assert m.ngeom == tiny_world.model.ngeom and m.nmesh == tiny_world.model.nmesh
    np.testing.assert_array_equal(m.hfield_data, tiny_world.model.hfield_data)
    np.testing.assert_allclose(m.geom_pos, tiny_world.model.geom_pos, atol=1e-3)  # MJCF prints 6 digits
    doc = json.loads((tmp_path / "w" / "truth.json").read_text())
    assert len(doc["objects"]) == len(tiny_world.truth.objects)
    names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(m.ngeom)}
    assert {f"obj{o.id}_0" for o in tiny_world.truth.objects} <= names


def test_load_world_round_trip(tiny_world: World, tmp_path) -> None:
    export_world(tiny_world, tmp_path / "w")
    back = load_world(tmp_path / "w")
    assert back.seed == tiny_world.seed and back.spec == tiny_world.spec
    assert len(back.truth.objects) == len(tiny_world.truth.objects)
    np.testing.assert_array_equal(back.truth.terrain.heights, tiny_world.truth.terrain.heights)
    for a, b in zip(back.truth.objects, tiny_world.truth.objects):
        assert a.family == b.family and a.geom_ids == b.geom_ids
        np.testing.assert_allclose(a.T_world_obj, b.T_world_obj, atol=1e-6)
    for name, mesh in tiny_world.meshes.items():
        np.testing.assert_allclose(back.meshes[name].vertices, mesh.vertices, atol=1e-6)
    assert len(back.truth.roads) == len(tiny_world.truth.roads)
    # an exported world exports again
    assert export_world(back, tmp_path / "again").is_file()


@pytest.mark.parametrize("damage", ["missing_truth", "bad_json", "bad_xml", "missing_mesh"])
def test_corrupt_folders_raise_world_error(tiny_world: World, tmp_path, damage: str) -> None:
    d = tmp_path / "w"
    export_world(tiny_world, d)
    if damage == "missing_truth":
        (d / "truth.json").unlink()
    elif damage == "bad_json":
        (d / "truth.json").write_text("{not json")
    elif damage == "bad_xml":
        (d / "world.xml").write_text("<mujoco><worldbody><geom type='nonsense'/></worldbody></mujoco>")
    else:
        next((d / "meshes").glob("*.msh")).unlink()
    with pytest.raises(WorldError, match=str(d)):
        load_world(d)
