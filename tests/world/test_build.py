"""Generated worlds against their own ground truth (every preset, determinism, placement)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.spatial import cKDTree

from roman_sim.core.errors import WorldError
from roman_sim.world import WORLD_PRESETS, World, export_world, generate, load_world_spec
from roman_sim.world.query import is_free, road_distance


def _check_world(world: World) -> None:
    """Invariants every generated world must satisfy."""
    m, truth = world.model, world.truth
    objs = truth.objects
    assert [o.id for o in objs] == list(range(len(objs)))
    assert m.ngeom == 1 + sum(len(o.mesh_names) for o in objs)
    lut = truth.geom_to_object(m.ngeom)
    assert lut[0] == -1 and m.geom_type[0] == mujoco.mjtGeom.mjGEOM_HFIELD
    for o in objs:
        assert all(lut[g] == o.id for g in o.geom_ids)
        assert set(o.mesh_names) <= set(world.meshes)
    assert m.vis.global_.offwidth >= 1280 and m.vis.global_.offheight >= 960
    assert m.vis.quality.shadowsize == 0 and m.nlight >= 1 and m.njnt == 0
    if objs and truth.roads and world.spec.roads.width_m > 0:
        xy = np.stack([o.T_world_obj[:2, 3] for o in objs])
        radii = np.array([o.radius for o in objs])
        assert np.all(road_distance(truth, xy) >= world.spec.roads.width_m / 2 + radii - 1e-9)


@pytest.mark.parametrize("preset", WORLD_PRESETS.names())
def test_every_preset_builds_and_compiles(preset: str) -> None:
    world = generate(load_world_spec(preset), 0)
    assert len(world.truth.objects) >= 20
    assert world.truth.meta is not None
    counts = world.truth.meta.placed_requested
    assert sum(p for p, _ in counts.values()) == len(world.truth.objects)
    assert all(0 < p <= r for p, r in counts.values())
    if preset == "forest":  # the benchmark world: 200 x 200 m with >= 1000 objects
        assert len(world.truth.objects) >= 1000
    assert world.truth.roads, "every preset has a road network"
    _check_world(world)


def test_same_seed_same_bytes_other_seed_differs(tmp_path) -> None:
    spec = load_world_spec("tiny")
    a, b, c = (export_world(generate(spec, s), tmp_path / n).parent for n, s in (("a", 5), ("b", 5), ("c", 6)))
    for name in ("world.xml", "truth.json"):
        assert (a / name).read_bytes() == (b / name).read_bytes()
        assert (a / name).read_bytes() != (c / name).read_bytes()


def test_objects_rest_on_terrain(tiny_world: World) -> None:
    t = tiny_world.truth.terrain
    grad = np.abs(np.gradient(t.heights, t.size_x / (t.shape[1] - 1))).max()
    for o in tiny_world.truth.objects:
        x, y, z = o.T_world_obj[:3, 3]
        mesh = tiny_world.object_mesh_world(o.id)
        assert mesh.vertices[:, 2].min() == pytest.approx(z, abs=1e-6)
        sink = float(t.height_at(x, y)) - z
        assert -1e-9 <= sink <= grad * o.radius + 1e-6
        # no part of the base floats: the ring under the footprint is not below the base
        a = np.linspace(0, 2 * np.pi, 8, endpoint=False)
        ring = t.height_at(x + o.radius * np.cos(a), y + o.radius * np.sin(a))
        assert np.all(ring >= z - 1e-9)


@pytest.mark.parametrize("preset", ["tiny", "suburb", "offroad"])
def test_no_two_objects_overlap(small_spec, preset: str) -> None:
    world = generate(small_spec(preset, 80.0), 1) if preset != "tiny" else generate(load_world_spec(preset), 1)
    objs = world.truth.objects
    xy = np.stack([o.T_world_obj[:2, 3] for o in objs])
    r = np.array([o.radius for o in objs])
    for i, j in cKDTree(xy).query_pairs(2 * r.max()):
        assert np.hypot(*(xy[i] - xy[j])) >= r[i] + r[j] + world.spec.layout.min_gap_m - 1e-9
    for o in objs:  # the footprint radius really bounds the mesh
        v = world.object_mesh_world(o.id).vertices
        assert np.hypot(*(v[:, :2] - o.T_world_obj[:2, 3]).T).max() <= o.radius + 1e-6


def test_truth_matches_compiled_geom_poses(tiny_world: World) -> None:
    m = tiny_world.model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for o in tiny_world.truth.objects:
        for g, name in zip(o.geom_ids, o.mesh_names):
            mid = m.geom_dataid[g]
            assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, mid) == name
            R_mesh = np.zeros(9)
            mujoco.mju_quat2Mat(R_mesh, m.mesh_quat[mid])
            expect_R = o.T_world_obj[:3, :3] @ R_mesh.reshape(3, 3)
            expect_p = o.T_world_obj[:3, :3] @ m.mesh_pos[mid] + o.T_world_obj[:3, 3]
            np.testing.assert_allclose(d.geom_xpos[g], expect_p, atol=1e-9)
            np.testing.assert_allclose(d.geom_xmat[g].reshape(3, 3), expect_R, atol=1e-9)
        # centroid and oriented box are consistent with the world-frame mesh
        mesh = tiny_world.object_mesh_world(o.id)
        local = (mesh.vertices - o.obb_T_world[:3, 3]) @ o.obb_T_world[:3, :3]
        assert np.all(np.abs(local) <= o.obb_extents / 2 + 1e-6)
        assert np.allclose(np.sort(o.obb_extents)[::-1], o.extents)


def test_terrain_truth_is_the_rendered_ground(tiny_world: World) -> None:
    m, t = tiny_world.model, tiny_world.truth.terrain
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    rows, cols = t.shape
    ii, jj = np.meshgrid(np.arange(1, rows - 1, 3), np.arange(1, cols - 1, 3), indexing="ij")
    xs = -t.size_x / 2 + jj.ravel() * t.size_x / (cols - 1)
    ys = -t.size_y / 2 + ii.ravel() * t.size_y / (rows - 1)
    free = is_free(tiny_world.truth, np.column_stack([xs, ys]), margin=0.2)
    assert free.sum() > 20
    geomid = np.zeros(1, np.int32)
    for x, y, i, j in zip(xs[free], ys[free], ii.ravel()[free], jj.ravel()[free]):
        dist = mujoco.mj_ray(m, d, np.array([x, y, 50.0]), np.array([0, 0, -1.0]), None, 1, -1, geomid)
        assert geomid[0] == 0
        assert 50.0 - dist == pytest.approx(t.heights[i, j], abs=1e-4)
        assert float(t.height_at(x, y)) == pytest.approx(t.heights[i, j], abs=1e-9)


def test_flat_terrain_and_bad_seed(small_spec) -> None:
    spec = small_spec("tiny", 40.0, terrain={"amplitude_m": 0.0})
    world = generate(spec, 0)
    assert np.ptp(world.truth.terrain.heights) == 0.0
    with pytest.raises(WorldError, match="seed"):
        generate(spec, -3)
    with pytest.raises(WorldError, match="obj_id"):
        world.object_mesh_world(10_000)


def test_ambiguity_knob_changes_the_world(small_spec) -> None:
    low = generate(small_spec("forest", 60.0, ambiguity=0.0), 0)
    high = generate(small_spec("forest", 60.0, ambiguity=1.0), 0)
    assert len(high.truth.families()) == 1 < len(low.truth.families())
    assert len({tuple(o.mesh_names) for o in high.truth.objects}) == 1
    assert len({round(float(o.T_world_obj[0, 0]), 9) for o in high.truth.objects}) == 1  # common yaw


def test_ground_texture_paints_the_roads_where_truth_has_them(tiny_world: World) -> None:
    from roman_sim.world.ground import GRASS, ROAD

    m, t = tiny_world.model, tiny_world.truth.terrain
    tid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TEXTURE, "ground")
    w, h = int(m.tex_width[tid]), int(m.tex_height[tid])
    img = m.tex_data[m.tex_adr[tid] : m.tex_adr[tid] + 3 * w * h].reshape(h, w, 3).astype(float)

    def texel(x: float, y: float) -> np.ndarray:  # row 0 at +y, column 0 at -x
        r = int((t.size_y / 2 - y) / t.size_y * h)
        c = int((x + t.size_x / 2) / t.size_x * w)
        return img[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2].reshape(-1, 3).mean(0)

    on_road = tiny_world.truth.roads[0][::5]
    far = np.array([[0.0, 0.0]])  # the tiny loop road keeps the centre clear
    assert road_distance(tiny_world.truth, far)[0] > tiny_world.spec.roads.width_m
    for x, y in on_road:
        px = texel(x, y)
        assert np.linalg.norm(px - ROAD) < np.linalg.norm(px - GRASS)
    px = texel(*far[0])
    assert np.linalg.norm(px - GRASS) < np.linalg.norm(px - ROAD)
