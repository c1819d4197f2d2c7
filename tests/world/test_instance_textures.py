"""Per-instance textures: every object part its own seeded realisation, the memory bound, the
shared-texture scope, and a ground that does not repeat."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, WorldError
from roman_sim.core.seeding import child_rng
from roman_sim.world import World, WorldSpec, generate
from roman_sim.world.appearance import texture_memory_mb
from roman_sim.world.ground import ground_texture
from roman_sim.world.mjcf import MATERIAL_PREFIX
from roman_sim.world.terrain import make_terrain
from roman_sim.world.textures import texture_images


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


def _texture_of(world: World, geom: int) -> np.ndarray:
    m = world.model
    tex = int(m.mat_texid[m.geom_matid[geom], mujoco.mjtTextureRole.mjTEXROLE_RGB])
    w, h, adr = int(m.tex_width[tex]), int(m.tex_height[tex]), int(m.tex_adr[tex])
    return np.asarray(m.tex_data[adr : adr + 3 * w * h]).reshape(h, w, 3)


@pytest.fixture(scope="module")
def world() -> World:
    return generate(_spec(), 0)


def test_every_object_part_has_its_own_seeded_texture(world: World) -> None:
    objs = world.truth.objects
    n_parts = sum(len(o.geom_ids) for o in objs)
    assert len(objs) >= 10 and world.model.ntex == n_parts + 2  # + sky and ground
    assert len({int(world.model.geom_matid[g]) for o in objs for g in o.geom_ids}) == n_parts
    px = world.spec.appearance.texture_px
    for o in objs[:4]:
        for k, g in enumerate(o.geom_ids):
            name = mujoco.mj_id2name(world.model, mujoco.mjtObj.mjOBJ_MATERIAL, int(world.model.geom_matid[g]))
            kind = name[len(MATERIAL_PREFIX) :].split("_")[0]
            want = texture_images(kind, [child_rng(0, "world", "appearance", "texture", o.id, k)], px)[0]
            np.testing.assert_array_equal(_texture_of(world, g), want)
    # one shape everywhere (size_variation 0), a different pattern on every instance
    same_mesh = [o for o in objs if o.mesh_names == objs[0].mesh_names]
    a, b = (_texture_of(world, o.geom_ids[-1]).astype(np.float64)[..., 0] for o in same_mesh[:2])
    assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < 0.1


def test_a_texture_is_the_same_whatever_else_is_in_the_world() -> None:
    """Each texture draws from its own stream: batching and the other parts change nothing."""
    rngs = [child_rng(0, "t", i) for i in range(70)]
    batch = texture_images("foliage", rngs, 32)
    alone = texture_images("foliage", [child_rng(0, "t", 69)], 32)[0]
    np.testing.assert_array_equal(batch[69], alone)
    assert batch.dtype == np.uint8 and batch.shape == (70, 32, 32, 3)


def test_surface_scope_shares_one_texture_per_kind(world: World) -> None:
    shared = generate(_spec(texture_scope="surface"), 0)
    assert shared.model.ntex == 3 + 2  # bark, foliage, rock + sky and ground
    same_mesh = [o for o in shared.truth.objects if o.mesh_names == shared.truth.objects[0].mesh_names]
    a, b = (_texture_of(shared, o.geom_ids[-1]) for o in same_mesh[:2])
    np.testing.assert_array_equal(a, b)
    # geometry, colours and truth do not depend on the scope
    np.testing.assert_array_equal(shared.model.geom_rgba, world.model.geom_rgba)
    assert [o.to_dict() for o in shared.truth.objects] == [o.to_dict() for o in world.truth.objects]


def test_texture_memory_is_stated_and_bounded(world: World) -> None:
    n_parts = sum(len(o.geom_ids) for o in world.truth.objects)
    px = world.spec.appearance.texture_px
    assert world.model.ntexdata >= n_parts * px * px * 3
    assert texture_memory_mb(n_parts, px) == pytest.approx(n_parts * px * px * 3 / 2**20)
    bound = 0.5 * texture_memory_mb(n_parts, px)
    with pytest.raises(WorldError) as err:
        generate(_spec(texture_memory_mb=bound), 0)
    msg = str(err.value)
    fit = int(np.sqrt(bound * 2**20 / (3 * n_parts)))
    assert "\n" not in msg and msg.startswith("appearance.texture_memory_mb: "), msg
    assert f"{n_parts} object parts" in msg and f"appearance.texture_px <= {fit}" in msg, msg
    assert "texture_scope: surface" in msg, msg
    generate(_spec(texture_memory_mb=bound, texture_px=fit), 0)  # what the message allows fits
    generate(_spec(texture_memory_mb=bound, texture_scope="surface"), 0)


@pytest.mark.parametrize(
    ("appearance", "field", "hint"),
    [
        ({"texture_scope": "object"}, "appearance.texture_scope", "'instance' or 'surface'"),
        ({"texture_memory_mb": 0}, "appearance.texture_memory_mb", "greater than 0"),
        ({"texture_memory_mb": 1e5}, "appearance.texture_memory_mb", "less than or equal to 8192"),
    ],
)
def test_bad_texture_settings_name_the_field(appearance: dict, field: str, hint: str) -> None:
    with pytest.raises(ConfigError) as err:
        _spec(**appearance)
    msg = str(err.value)
    assert "\n" not in msg and f"{field}:" in msg and hint in msg, msg


def test_the_ground_does_not_repeat_at_submap_scale() -> None:
    """A 15 m ground patch looks like no other patch up to 30 m away (submaps are ~15 m across)."""
    spec = _spec()
    extent = (120.0, 120.0)
    terrain, _, _ = make_terrain(spec.terrain, extent, child_rng(0, "world", "terrain"))
    img = ground_texture(terrain, [], 0.0, child_rng(0, "world", "ground")).astype(np.float64)[..., 1]
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
