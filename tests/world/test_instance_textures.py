"""Per-instance textures: every object part its own seeded region of its surface's atlas, the
memory bound, the shared-texture scope, and a ground that does not repeat."""

from __future__ import annotations

import itertools

import mujoco
import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, WorldError
from roman_sim.core.seeding import child_rng
from roman_sim.world import World, WorldSpec, generate
from roman_sim.world.appearance import ground_memory_mb, ground_shape, texture_memory_mb
from roman_sim.world.catalog import family_assets
from roman_sim.world.ground import ground_texture
from roman_sim.world.mjcf import MATERIAL_PREFIX, instance_mesh_name, shape_of
from roman_sim.world.terrain import make_terrain
from roman_sim.world.textures import (
    SURFACES,
    TEXTURE_MEAN,
    box_uv,
    instance_uv,
    texture_image,
    texture_images,
)
from roman_sim.world.truth import ObjectTruthRow


def _spec(**appearance: object) -> WorldSpec:
    return validate_model(
        WorldSpec,
        {
            "name": "parts",
            "extent_m": [50.0, 50.0],
            "terrain": {"amplitude_m": 0.0},
            "families": [{"name": "conifer", "density": 30}, {"name": "boulder", "density": 30}],
            "layout": {"min_gap_m": 1.0},
            "roads": {"style": "loop", "width_m": 3.0},
            "size_variation": 0.0,
            "appearance": {"textures": True, **appearance},
        },
    )


def _atlas(world: World, kind: str) -> np.ndarray:
    m = world.model
    tex = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TEXTURE, f"{MATERIAL_PREFIX}{kind}")
    w, h, adr = int(m.tex_width[tex]), int(m.tex_height[tex]), int(m.tex_adr[tex])
    return np.asarray(m.tex_data[adr : adr + 3 * w * h]).reshape(h, w, 3)[..., 0]


def _texcoords(world: World, geom: int) -> np.ndarray:
    """(3F, 2) texture coordinates of a geom's mesh, per face corner."""
    m = world.model
    mesh = int(m.geom_dataid[geom])
    adr, fadr, fnum = int(m.mesh_texcoordadr[mesh]), int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
    idx = m.mesh_facetexcoord[fadr : fadr + fnum].ravel()
    return m.mesh_texcoord[adr + idx]


def _seen(world: World, geom: int, kind: str) -> np.ndarray:
    """The atlas texel under each face corner of a geom (what the instance shows there)."""
    atlas = _atlas(world, kind)
    px = np.floor(np.mod(_texcoords(world, geom), 1.0) * atlas.shape[0]).astype(int)
    return atlas[px[:, 1], px[:, 0]].astype(np.float64)


@pytest.fixture(scope="module")
def world() -> World:
    return generate(_spec(), 0)


def test_every_object_part_looks_at_its_own_seeded_region_of_its_atlas(world: World) -> None:
    objs, m = world.truth.objects, world.model
    n_parts = sum(len(o.geom_ids) for o in objs)
    app = world.spec.appearance
    assert len(objs) >= 10 and m.nmesh == n_parts and m.ntex == 3 + 2  # bark, foliage, rock + sky, ground
    side = app.texture_px * app.atlas_tiles
    for kind in ("bark", "foliage", "rock"):
        want = texture_image(kind, child_rng(0, "world", "appearance", "texture", kind), side, app.texture_px)
        np.testing.assert_array_equal(_atlas(world, kind), want[..., 0])
    parts = {a.mesh_name(p): p for f in world.spec.families for a in family_assets(0, f, 0.0) for p in a.parts}
    for o in objs[:4]:
        for k, (g, shape) in enumerate(zip(o.geom_ids, o.mesh_names)):
            part = parts[shape]
            uv, _ = box_uv(part.mesh, SURFACES.get(part.surface).tile_m, part.grain_axis)
            rng = child_rng(0, "world", "appearance", "texture", o.id, k)
            np.testing.assert_allclose(_texcoords(world, g), instance_uv(uv, part.surface, app.atlas_tiles, rng))
            mesh = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, int(m.geom_dataid[g]))
            assert mesh == instance_mesh_name(shape, o.id) and shape_of(mesh) == shape
    # one shape everywhere (size_variation 0), and every instance shows its own pattern on it
    crowns = [(o.geom_ids[1], "foliage") for o in objs if o.family == "conifer"]
    seen = [_seen(world, g, kind) for g, kind in crowns[:4]]
    for a, b in itertools.combinations(seen, 2):
        assert abs(np.corrcoef(a, b)[0, 1]) < 0.3


def test_a_texture_is_the_same_whatever_else_is_in_the_batch() -> None:
    """Each texture draws from its own stream: the other images of a batch change nothing."""
    rngs = [child_rng(0, "t", i) for i in range(5)]
    batch = texture_images("foliage", rngs, 64, 32)
    alone = texture_images("foliage", [child_rng(0, "t", 4)], 64, 32)[0]
    np.testing.assert_array_equal(batch[4], alone)
    assert batch.dtype == np.uint8 and batch.shape == (5, 64, 64, 3)


def test_an_atlas_is_one_periodic_realisation_at_the_tile_scale() -> None:
    """Several tiles of one kind wrap without a seam and keep one tile's feature sizes."""
    for kind in SURFACES.names():
        atlas = texture_image(kind, child_rng(1, kind), 4 * 32, 32).astype(np.float64)[..., 0]
        tile = texture_image(kind, child_rng(1, kind), 32).astype(np.float64)[..., 0]
        steps_u = np.abs(np.diff(atlas, axis=1)).mean(axis=0)
        steps_v = np.abs(np.diff(atlas, axis=0)).mean(axis=1)
        assert np.abs(atlas[:, 0] - atlas[:, -1]).mean() <= steps_u.max() + 1e-9, kind
        assert np.abs(atlas[0] - atlas[-1]).mean() <= steps_v.max() + 1e-9, kind
        # the same pixel-to-pixel roughness as a one-tile texture (features scale with the tile)
        assert steps_u.mean() == pytest.approx(np.abs(np.diff(tile, axis=1)).mean(), rel=0.25), kind
        assert abs(atlas.mean() / 255.0 - TEXTURE_MEAN) < 0.02, kind


def test_surface_scope_shares_one_tile_per_kind(world: World) -> None:
    shared = generate(_spec(texture_scope="surface"), 0)
    m = shared.model
    assert m.ntex == 3 + 2 and m.nmesh == len(shared.meshes) < world.model.nmesh
    assert int(m.tex_width[m.ntex - 1]) == shared.spec.appearance.texture_px
    same = [o for o in shared.truth.objects if o.family == "conifer"]
    np.testing.assert_array_equal(_texcoords(shared, same[0].geom_ids[1]), _texcoords(shared, same[1].geom_ids[1]))
    # geometry, colours and truth do not depend on the scope
    np.testing.assert_array_equal(m.geom_rgba, world.model.geom_rgba)
    assert [ObjectTruthRow.of(o) for o in shared.truth.objects] == [ObjectTruthRow.of(o) for o in world.truth.objects]
    assert shared.meshes.keys() == world.meshes.keys()


def test_texture_memory_is_stated_and_bounded(world: World) -> None:
    app = world.spec.appearance
    side = app.texture_px * app.atlas_tiles
    assert texture_memory_mb(3, side) == pytest.approx(3 * side * side * 3 / 2**20)
    rows, cols = ground_shape(world.spec.extent_m, 0.025)
    assert (rows, cols) == (2000, 2000)  # 50 m at 2.5 cm
    assert ground_memory_mb(app, world.spec.extent_m) == pytest.approx(rows * cols * 3 / 2**20)
    assert world.model.ntexdata == 3 * side * side * 3 + 64 * 64 * 6 * 3 + 3 * rows * cols
    ground = ground_memory_mb(app, world.spec.extent_m)
    bound = ground + 0.5 * texture_memory_mb(3, side)
    with pytest.raises(WorldError) as err:
        generate(_spec(texture_memory_mb=bound), 0)
    msg = str(err.value)
    tiles = int(np.sqrt((bound - ground) * 2**20 / (3 * 3))) // app.texture_px
    assert "\n" not in msg and msg.startswith("appearance.texture_memory_mb: 3 surface atlases of "), msg
    assert f"appearance.atlas_tiles <= {tiles}" in msg and "texture_scope: surface" in msg, msg
    assert "ground image of 2000 x 2000 px" in msg and "ground_texel_m" not in msg, msg  # atlases alone are over
    generate(_spec(texture_memory_mb=bound, atlas_tiles=tiles), 0)  # what the message allows fits
    generate(_spec(texture_memory_mb=bound, texture_scope="surface"), 0)


def test_the_ground_image_counts_towards_the_bound() -> None:
    """A bound the atlases fit but not the ground fails naming a ground texel that fits."""
    spec = _spec()
    atlases = texture_memory_mb(3, spec.appearance.texture_side_px())
    bound = atlases + 0.5 * ground_memory_mb(spec.appearance, spec.extent_m)
    with pytest.raises(WorldError) as err:
        generate(_spec(texture_memory_mb=bound), 0)
    texel = float(str(err.value).split("appearance.ground_texel_m >= ")[1].split(",")[0])
    assert 0.025 < texel < 0.05, texel
    world = generate(_spec(texture_memory_mb=bound, ground_texel_m=texel), 0)  # what the message allows fits
    assert world.model.ntexdata / 2**20 <= bound + 1.0  # the sky is not counted
    plain = generate(_spec(texture_memory_mb=atlases, ground_texel_m=None), 0)
    tid = mujoco.mj_name2id(plain.model, mujoco.mjtObj.mjOBJ_TEXTURE, "ground")
    assert int(plain.model.tex_width[tid]) == 250  # the plain ground: 0.2 m texels, not counted


@pytest.mark.parametrize(
    ("appearance", "field", "hint"),
    [
        ({"texture_scope": "object"}, "appearance.texture_scope", "'instance' or 'surface'"),
        ({"texture_memory_mb": 0}, "appearance.texture_memory_mb", "greater than 0"),
        ({"texture_memory_mb": 1e5}, "appearance.texture_memory_mb", "less than or equal to 8192"),
        ({"texture_px": 512, "atlas_tiles": 32}, "appearance.atlas_tiles", "allowed: atlas_tiles <= 16"),
        ({"atlas_tiles": 1}, "appearance.atlas_tiles", "greater than or equal to 2"),
    ],
)
def test_bad_texture_settings_name_the_field(appearance: dict, field: str, hint: str) -> None:
    with pytest.raises(ConfigError) as err:
        _spec(**appearance)
    msg = str(err.value)
    assert "\n" not in msg and f"{field}:" in msg and hint in msg, msg


@pytest.mark.parametrize("texel", [None, 0.05])
def test_the_ground_does_not_repeat_at_submap_scale(texel: float | None) -> None:
    """A 15 m ground patch looks like no other patch up to 30 m away (submaps are ~15 m across),
    plain or detailed (the detailed one at 5 cm here, to keep the test quick)."""
    spec = _spec()
    extent = (120.0, 120.0)
    terrain, _, _ = make_terrain(spec.terrain, extent, child_rng(0, "world", "terrain"))
    img = ground_texture(terrain, [], 0.0, child_rng(0, "world", "ground"), texel).astype(np.float64)[..., 1]
    px_m = extent[0] / img.shape[1]
    side, step = int(15.0 / px_m), int(2.0 / px_m)
    ref = img[:side, :side].ravel()
    best = max(
        abs(np.corrcoef(ref, img[dy : dy + side, dx : dx + side].ravel())[0, 1])
        for dy in range(0, int(30.0 / px_m), step)
        for dx in range(0, int(30.0 / px_m), step)
        if (dx, dy) != (0, 0)
    )
    assert best < 0.2, best
