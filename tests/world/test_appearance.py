"""World appearance: per-instance colours, surface textures, lighting and shadows, checked on
rendered images against what the world says it drew (geom colours, sun angles, masks)."""

from __future__ import annotations

import colorsys
from collections.abc import Callable

import mujoco
import numpy as np
import pytest
from scipy.ndimage import binary_erosion, laplace

from roman_sim.core.config import apply_overrides, validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.sensors import backproject
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.render import SensorRenderer
from roman_sim.world import World, WorldSpec, export_world, generate, load_world
from roman_sim.world.appearance import LIGHTING, instance_draws, vary_rgba
from roman_sim.world.assets import FAMILIES
from roman_sim.world.catalog import family_assets
from roman_sim.world.textures import SURFACES, NoiseBatch
from roman_sim.world.truth import SunMeta

CAM = CameraConfig(width=160, height=120, hfov_deg=60.0, vfov_deg=None, far_m=100.0)
FLAT = {"sun": 0.0, "headlight": 0.0, "ambient": 1.0, "colour": [1.0, 1.0, 1.0]}  # lit colour = geom colour


def _spec(**appearance: object) -> WorldSpec:
    """A 30 x 30 m flat world of about a dozen well-separated bushes, boulders and conifers."""
    return validate_model(
        WorldSpec,
        {
            "name": "look",
            "extent_m": [30.0, 30.0],
            "terrain": {"amplitude_m": 0.0},
            "families": [
                {"name": "bush", "density": 40},
                {"name": "boulder", "density": 40},
                {"name": "conifer", "density": 30},
            ],
            "layout": {"min_gap_m": 2.0},
            "roads": {"style": "loop", "width_m": 3.0},
            "appearance": appearance,
        },
    )


def _topdown(x: float, y: float, z: float) -> np.ndarray:
    """Camera at (x, y, z) looking straight down; image right = world +x (east)."""
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = [1, 0, 0], [0, -1, 0], [0, 0, -1], [x, y, z]
    return T


def _view_of(world: World, obj_id: int) -> np.ndarray:
    o = world.truth.objects[obj_id]
    top = o.obb_T_world[2, 3] + o.obb_extents[2] / 2
    return _topdown(o.centroid[0], o.centroid[1], top + 2.5 * o.radius)


def _render(world: World, poses: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    with SensorRenderer(world, CAM) as r:
        return [r.render(T) for T in poses]  # type: ignore[misc]


def _of(world: World, family: str) -> list[int]:
    return [o.id for o in world.truth.objects if o.family == family]


@pytest.fixture(scope="module")
def gen() -> Callable[..., World]:
    cache: dict[str, World] = {}

    def make(**appearance: object) -> World:
        key = repr(sorted(appearance.items()))
        if key not in cache:
            cache[key] = generate(_spec(**appearance), 0)
        return cache[key]

    return make


# --- configuration -------------------------------------------------------------------------


def test_defaults_and_presets_resolve() -> None:
    app = _spec().appearance
    assert (app.textures, app.shadows, app.instance_variation) == (False, False, 0.5)
    assert app.lighting == LIGHTING.get("noon")
    assert _spec(lighting="overcast").appearance.lighting == LIGHTING.get("overcast")
    mixed = _spec(lighting={"preset": "morning", "elevation_deg": 33.0}).appearance.lighting
    assert mixed.elevation_deg == 33.0 and mixed.azimuth_deg == LIGHTING.get("morning").azimuth_deg
    assert set(LIGHTING.names()) >= {"noon", "morning", "evening", "overcast", "random"}


@pytest.mark.parametrize(
    ("appearance", "field", "hint"),
    [
        ({"lighting": "dusk"}, "appearance.lighting", "valid: evening, morning, noon, overcast, random"),
        ({"lighting": {"preset": "dusk"}}, "appearance.lighting", "unknown lighting preset 'dusk'"),
        ({"lighting": {"azimuth": 3}}, "appearance.lighting.azimuth", "unknown key"),
        ({"lighting": {"elevation_deg": 95}}, "appearance.lighting.elevation_deg", "less than or equal to 90"),
        ({"lighting": {"colour": [1.2, 1, 1]}}, "appearance.lighting.colour", "each channel must be in [0, 1]"),
        ({"instance_variation": 1.5}, "appearance.instance_variation", "less than or equal to 1"),
        ({"textures": "sometimes"}, "appearance.textures", "valid boolean"),
        ({"shine": True}, "appearance.shine", "unknown key"),
    ],
)
def test_bad_appearance_is_one_line_naming_the_field(appearance: dict, field: str, hint: str) -> None:
    with pytest.raises(ConfigError) as err:
        _spec(**appearance)
    msg = str(err.value)
    assert "\n" not in msg and f"{field}:" in msg and hint in msg, msg


def test_every_family_part_has_a_known_surface() -> None:
    for fam in FAMILIES.names():
        for part in FAMILIES.get(fam)(np.random.default_rng(0)):
            assert part.surface in SURFACES, (fam, part.name, part.surface)


# --- per-instance colour ---------------------------------------------------------------------


def _hsv(rgb: np.ndarray) -> tuple[float, float, float]:
    h, s, v = colorsys.rgb_to_hsv(*(np.asarray(rgb, dtype=np.float64) / 255.0))
    return 360.0 * h, s, v


def test_instance_colours_are_the_seeded_draws_within_the_family_range(gen: Callable[..., World]) -> None:
    """Ambient-only white light draws each geom in its own colour: the image shows the seeded colour."""
    amount = 0.8
    world = gen(lighting=FLAT, instance_variation=amount)
    ids = _of(world, "bush") + _of(world, "boulder")
    assert len(ids) >= 6
    bases = {
        a.mesh_name(a.parts[0]): a.parts[0].rgba
        for f in world.spec.families
        for a in family_assets(0, f, world.spec.knobs()[1])
    }
    for obj_id, (rgb, _, seg) in zip(ids, _render(world, [_view_of(world, i) for i in ids])):
        obj = world.truth.objects[obj_id]
        mask = seg == obj_id
        assert mask.sum() > 500
        seen = rgb[mask].astype(np.float64).mean(axis=0)
        base = bases[obj.mesh_names[0]]
        var = SURFACES.get("foliage" if obj.family == "bush" else "rock").variation
        want = vary_rgba(base, var, amount, instance_draws(0, obj_id, 1)[0])
        np.testing.assert_allclose(seen, 255.0 * want[:3], atol=0.51)  # 8-bit rounding only
        (h, s, v), (h0, s0, v0) = _hsv(seen), _hsv(255.0 * np.asarray(base[:3]))
        assert abs((h - h0 + 180.0) % 360.0 - 180.0) <= amount * var.hue_deg + 0.5
        assert abs(s - s0) <= amount * var.sat + 0.01
        assert v0 * (1 - amount * var.val) - 0.01 <= v <= v0 * (1 + amount * var.val) + 0.01


def test_two_instances_of_one_shape_differ_by_their_draws(gen: Callable[..., World]) -> None:
    amount = 1.0
    world = gen(lighting=FLAT, instance_variation=amount)
    by_mesh: dict[str, list[int]] = {}
    for i in _of(world, "boulder") + _of(world, "bush"):
        by_mesh.setdefault(world.truth.objects[i].mesh_names[0], []).append(i)
    a, b = next(v[:2] for v in by_mesh.values() if len(v) >= 2)
    (ra, _, sa), (rb, _, sb) = _render(world, [_view_of(world, a), _view_of(world, b)])
    ha, _, va = _hsv(ra[sa == a].astype(np.float64).mean(axis=0))
    hb, _, vb = _hsv(rb[sb == b].astype(np.float64).mean(axis=0))
    da, db = instance_draws(0, a, 1)[0], instance_draws(0, b, 1)[0]
    var = SURFACES.get("rock" if world.truth.objects[a].family == "boulder" else "foliage").variation
    dh = (ha - hb + 180.0) % 360.0 - 180.0
    assert dh == pytest.approx(amount * var.hue_deg * (da[0] - db[0]), abs=1.5)
    assert va / vb == pytest.approx((1 + amount * var.val * da[2]) / (1 + amount * var.val * db[2]), rel=0.02)
    same = gen(lighting=FLAT, instance_variation=0.0)
    (ra0, _, sa0), (rb0, _, sb0) = _render(same, [_view_of(same, a), _view_of(same, b)])
    np.testing.assert_allclose(ra0[sa0 == a].mean(axis=0), rb0[sb0 == b].mean(axis=0), atol=0.51)


# --- textures --------------------------------------------------------------------------------


def _masked_laplacian_var(rgb: np.ndarray, mask: np.ndarray) -> float:
    inner = binary_erosion(mask, iterations=2)  # object edges are not texture
    return float(laplace(rgb.astype(np.float64).mean(axis=2))[inner].var())


def test_textures_put_texture_on_objects(gen: Callable[..., World]) -> None:
    plain, textured = gen(), gen(textures=True)
    ids = _of(plain, "bush") + _of(plain, "boulder") + _of(plain, "conifer")
    poses = [_view_of(plain, i) for i in ids]
    for obj_id, (a, _, sa), (b, _, sb) in zip(ids, _render(plain, poses), _render(textured, poses)):
        off, on = _masked_laplacian_var(a, sa == obj_id), _masked_laplacian_var(b, sb == obj_id)
        # measured: bushes and conifers 1-12 -> 55-100, boulders (faceted) 35-107 -> 200-305
        assert on > 2.5 * off and on > 40.0, (plain.truth.objects[obj_id].family, off, on)


def test_textured_colour_keeps_the_instance_hue(gen: Callable[..., World]) -> None:
    world = gen(lighting=FLAT, instance_variation=1.0, textures=True)
    ids = _of(world, "bush") + _of(world, "boulder")
    for obj_id, (rgb, _, seg) in zip(ids, _render(world, [_view_of(world, i) for i in ids])):
        geom = world.truth.objects[obj_id].geom_ids[0]
        h, s, _ = _hsv(rgb[seg == obj_id].astype(np.float64).mean(axis=0))
        h0, s0, _ = _hsv(255.0 * world.model.geom_rgba[geom, :3])
        if s0 > 0.1:  # hue is undefined for greys
            assert abs((h - h0 + 180.0) % 360.0 - 180.0) < 3.0
        assert s == pytest.approx(s0, abs=0.03)


def test_surface_textures_tile_and_have_their_grain() -> None:
    for kind in SURFACES.names():
        img = SURFACES.get(kind).texture(NoiseBatch([np.random.default_rng(1)], 128))[0].astype(np.float64)
        again = SURFACES.get(kind).texture(NoiseBatch([np.random.default_rng(1)], 128))[0]
        np.testing.assert_array_equal(img, again)
        steps_u = np.abs(np.diff(img, axis=1)).mean(axis=0)  # between neighbouring columns
        steps_v = np.abs(np.diff(img, axis=0)).mean(axis=1)  # between neighbouring rows
        # the wrap-around step (last column -> first) is one more ordinary step: no seam
        assert np.abs(img[:, 0] - img[:, -1]).mean() <= steps_u.max() + 1e-9, kind
        assert np.abs(img[0] - img[-1]).mean() <= steps_v.max() + 1e-9, kind
        step_u, step_v = steps_u.mean(), steps_v.mean()
        if kind in ("bark", "wood", "metal", "straw"):
            assert step_v < 0.6 * step_u, kind  # streaks run along v


# --- lighting and shadows --------------------------------------------------------------------


def _east_west(rgb: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """Mean brightness of the east and west halves of a top-down object mask."""
    grey, u = rgb.astype(np.float64).mean(axis=2), np.arange(rgb.shape[1])[None, :]
    mid = np.median(np.nonzero(mask)[1])
    return float(grey[mask & (u > mid)].mean()), float(grey[mask & (u < mid)].mean())


def test_morning_lights_the_east_side_and_evening_the_west(gen: Callable[..., World]) -> None:
    morning, evening = gen(lighting="morning"), gen(lighting="evening")
    assert np.cos(np.radians(LIGHTING.get("morning").azimuth_deg)) > 0.5  # the morning sun is in the east
    ids = _of(morning, "boulder") + _of(morning, "bush")
    poses = [_view_of(morning, i) for i in ids]
    for obj_id, (rm, _, sm), (re, _, se) in zip(ids, _render(morning, poses), _render(evening, poses)):
        east, west = _east_west(rm, sm == obj_id)
        assert east > west + 10, ("morning", obj_id, east, west)
        east, west = _east_west(re, se == obj_id)
        assert west > east + 10, ("evening", obj_id, east, west)


def test_ground_brightness_follows_the_sun_elevation(gen: Callable[..., World]) -> None:
    """Flat ground under a sun only: brightness ~ sin(elevation) (Lambert)."""
    sun_only = {"sun": 1.0, "ambient": 0.0, "headlight": 0.0, "colour": [1.0, 1.0, 1.0], "azimuth_deg": 0.0}
    low, high = gen(lighting={**sun_only, "elevation_deg": 30.0}), gen(lighting={**sun_only, "elevation_deg": 90.0})
    pose = [_topdown(0.0, 0.0, 12.0)]
    (a, da, sa), (b, _, _) = _render(low, pose)[0], _render(high, pose)[0]
    ground = (sa == -1) & (da > 0)
    ratio = a[ground].astype(np.float64).mean() / b[ground].astype(np.float64).mean()
    assert ratio == pytest.approx(np.sin(np.radians(30.0)), abs=0.01)
    assert low.truth.meta is not None and low.truth.meta.sun == SunMeta(azimuth_deg=0.0, elevation_deg=30.0)


def test_shadows_darken_the_ground_behind_an_object_only(gen: Callable[..., World]) -> None:
    light = {"azimuth_deg": 0.0, "elevation_deg": 40.0, "sun": 0.5, "ambient": 0.3, "headlight": 0.2}
    off, on = gen(lighting=light), gen(lighting=light, shadows=True)
    assert off.model.vis.quality.shadowsize == 0 and on.model.vis.quality.shadowsize > 0
    tree = off.truth.objects[_of(off, "conifer")[0]]
    x0, y0 = tree.T_world_obj[:2, 3]
    T = _topdown(x0 - 4.0, y0, tree.obb_extents[2] + 12.0)
    means = {}
    for name, world in (("off", off), ("on", on)):
        rgb, depth, seg = _render(world, [T])[0]
        ground = (seg == -1) & (depth > 0)
        pts = backproject(depth, CAM.intrinsics(), ground) @ T[:3, :3].T + T[:3, 3]
        dx, dy = pts[:, 0] - x0, np.abs(pts[:, 1] - y0)
        grey = rgb[ground].astype(np.float64).mean(axis=1)
        behind, before = (dx < -1.5) & (dx > -5.0) & (dy < 0.8), (dx > 1.5) & (dx < 5.0) & (dy < 0.8)
        assert behind.sum() > 100 and before.sum() > 100
        means[name] = grey[behind].mean(), grey[before].mean()
    assert means["on"][0] < 0.8 * means["off"][0]  # the tree's shadow falls away from the sun (west)
    assert means["on"][1] == pytest.approx(means["off"][1], abs=1.5)  # the sunny side is unchanged


def test_random_lighting_is_seeded() -> None:
    metas = [generate(_spec(lighting="random"), s).truth.meta for s in (4, 4, 5)]
    a, b, c = (m.sun for m in metas if m is not None)
    assert a == b and a != c
    for sun in (a, c):
        assert 0.0 <= sun.azimuth_deg < 360.0 and 15.0 <= sun.elevation_deg <= 75.0


# --- what appearance must not change -------------------------------------------------------


def test_depth_and_ids_do_not_depend_on_appearance(gen: Callable[..., World]) -> None:
    plain = gen()
    fancy = gen(textures=True, instance_variation=1.0, lighting="evening", shadows=True)
    poses = [_view_of(plain, i) for i in (0, 4, 8)]
    o = plain.truth.objects[2].T_world_obj[:3, 3]
    side = np.eye(4)
    side[:3, :3] = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], dtype=np.float64).T  # looking along +x
    side[:3, 3] = [o[0] - 6.0, o[1], 1.0]
    poses.append(side)
    for (ra, da, sa), (rb, db, sb) in zip(_render(plain, poses), _render(fancy, poses)):
        np.testing.assert_array_equal(da, db)
        np.testing.assert_array_equal(sa, sb)
        assert (sa >= 0).any() and not np.array_equal(ra, rb)


def test_same_seed_same_rgb_bytes() -> None:
    spec = _spec(textures=True, instance_variation=1.0, lighting="random", shadows=True)
    a, b = generate(spec, 3), generate(spec, 3)
    pose = [_view_of(a, 1)]
    assert _render(a, pose)[0][0].tobytes() == _render(b, pose)[0][0].tobytes()


def test_textured_world_exports_and_reloads_in_plain_mujoco(gen: Callable[..., World], tmp_path) -> None:
    world = gen(textures=True, instance_variation=1.0, lighting="morning", shadows=True)
    xml = export_world(world, tmp_path / "w")
    m, g = mujoco.MjModel.from_xml_path(str(xml)), world.model
    assert m.ntex == g.ntex and m.nmat == g.nmat and m.nmeshtexcoord == g.nmeshtexcoord > 0
    np.testing.assert_array_equal(m.tex_data, g.tex_data)
    np.testing.assert_array_equal(m.mesh_facetexcoord, g.mesh_facetexcoord)
    np.testing.assert_allclose(m.mesh_texcoord, g.mesh_texcoord, atol=1e-6)
    np.testing.assert_array_equal(m.geom_matid, g.geom_matid)
    np.testing.assert_allclose(m.geom_rgba, g.geom_rgba, atol=1e-6)
    np.testing.assert_allclose(m.light_dir, g.light_dir, atol=1e-6)
    assert m.vis.quality.shadowsize == g.vis.quality.shadowsize and bool(m.light_castshadow[0])
    back = load_world(tmp_path / "w")
    assert back.spec == world.spec
    for name, mesh in world.meshes.items():
        np.testing.assert_array_equal(back.meshes[name].faces, mesh.faces)
        np.testing.assert_allclose(back.meshes[name].vertices, mesh.vertices, atol=1e-6)
    again = load_world(export_world(back, tmp_path / "again").parent)
    np.testing.assert_allclose(again.model.mesh_texcoord, g.mesh_texcoord, atol=1e-6)


def test_appearance_takes_dotted_overrides() -> None:
    data = apply_overrides(
        _spec().model_dump(mode="json"),
        ["appearance.lighting=evening", "appearance.shadows=true", "appearance.textures=true"],
    )
    app = validate_model(WorldSpec, data).appearance
    assert app.lighting == LIGHTING.get("evening") and app.shadows and app.textures
    data = apply_overrides(_spec().model_dump(mode="json"), ["appearance.lighting.azimuth_deg=90"])
    assert validate_model(WorldSpec, data).appearance.lighting.azimuth_deg == 90.0
