"""What the simulated encoder may know of how a world draws its objects (``SceneLooks``).

Everything here is read from the values the renderer uses, never drawn anew: each object's
shape variant and scale level (its assets' names and the world's scale levels), each part's
colour (the compiled model's geom colour, in CIELAB), its share of the surface, its region of
its surface atlas with per-instance textures (``textures.instance_region`` on the stream the
world's texture coordinates were drawn from), its heading, and the light of the robot (its
own lighting preset, else the world's). A shape's front-back asymmetry is measured on its
scale-1 parts with their family colours (``roman_sim.frontend.view_asymmetry``), once per
world seed, family and variant.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

from roman_sim.core.seeding import child_rng
from roman_sim.frontend.appearance import InstanceLooks, LooksRecord, PartLooks, SceneLight, SceneLooks, srgb_to_lab
from roman_sim.frontend.view_asymmetry import asymmetry
from roman_sim.interop.objects import TableLooks, read_objects_json
from roman_sim.world.appearance import LightingSpec, resolve_sun
from roman_sim.world.build import World
from roman_sim.world.catalog import scale_levels, variant_parts
from roman_sim.world.mjcf import MATERIAL_PREFIX, shape_of
from roman_sim.world.relight import robot_lighting
from roman_sim.world.textures import instance_region
from roman_sim.world.truth import ObjectTruth


@functools.lru_cache(maxsize=512)
def shape_asymmetry(seed: int, family: str, variant: int) -> float:
    """Front-back asymmetry of shape variant ``variant`` of ``family`` in the world of ``seed``."""
    parts = variant_parts(seed, family, variant)
    return asymmetry([(p.mesh.vertices, p.mesh.faces, p.rgba) for p in parts])


def _asset_key(obj: ObjectTruth) -> tuple[int, int, list[str]]:
    """(variant, scale level, part names) of ``obj`` from its mesh names ``{family}_v{v}_s{s}_{part}``."""
    names = []
    variant = level = 0
    for mesh in obj.mesh_names:
        v, s, part = shape_of(mesh)[len(obj.family) + 2 :].split("_", 2)
        variant, level = int(v), int(s[1:])
        names.append(part)
    return variant, level, names


def world_instances(world: World) -> dict[int, InstanceLooks]:
    """Object id -> how ``world`` draws it."""
    spec, model = world.spec, world.model
    app = spec.appearance
    per_instance = app.textures and app.texture_scope == "instance"
    size_variation = spec.knobs()[1]
    fams = {f.name: f for f in spec.families}
    out: dict[int, InstanceLooks] = {}
    for obj in world.truth.objects:
        variant, level, names = _asset_key(obj)
        scale = float(scale_levels(fams[obj.family], size_variation)[level])
        areas = np.array([world.meshes[shape_of(m)].area for m in obj.mesh_names], dtype=np.float64)
        areas = areas / areas.sum() if areas.sum() > 0 else np.full(len(areas), 1.0 / len(areas))
        parts = []
        for k, (name, geom) in enumerate(zip(names, obj.geom_ids)):
            texture = None
            if per_instance:
                mat = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_MATERIAL, int(model.geom_matid[geom]))
                rng = child_rng(world.seed, "world", "appearance", "texture", obj.id, k)
                sym, offset = instance_region(mat[len(MATERIAL_PREFIX) :], app.atlas_tiles, rng)
                texture = (sym, float(offset[0]), float(offset[1]))
            lab = srgb_to_lab(model.geom_rgba[geom][:3].tolist())
            parts.append(PartLooks(name, lab, float(areas[k]), texture))
        yaw = float(np.arctan2(obj.T_world_obj[1, 0], obj.T_world_obj[0, 0]))
        shape = f"{obj.family}_v{variant}"
        out[obj.id] = InstanceLooks(obj.family, shape, scale, yaw, tuple(parts), app.atlas_tiles if per_instance else 1)
    return out


def scene_light(lighting: LightingSpec, sun_azimuth_deg: float, sun_elevation_deg: float) -> SceneLight:
    """The encoder's view of a lighting: the sun's angles and its share of the light."""
    total = lighting.sun + lighting.ambient + lighting.headlight
    share = lighting.sun / total if total > 0 else 0.0
    return SceneLight(math.radians(sun_azimuth_deg), math.radians(sun_elevation_deg), share)


def robot_looks(world: World | None, robot: str, lighting_preset: str | None, seed: int) -> SceneLooks | None:
    """What robot ``robot``'s simulated encoder knows of ``world`` (None without a rendered world).

    Args:
        world: the generated world (None, or truth only: no looks).
        robot: the robot's name (keys a ``random`` lighting preset's sun).
        lighting_preset: the robot's own lighting preset (None: the world's lighting).
        seed: the scenario seed (the robot's lighting stream).
    """
    if not isinstance(world, World):
        return None
    instances = world_instances(world)
    shapes = {(o.family, int(o.shape.rsplit("_v", 1)[1])) for o in instances.values()}
    asym = {f"{f}_v{v}": shape_asymmetry(world.seed, f, v) for f, v in sorted(shapes)}
    own = robot_lighting(lighting_preset, seed, robot)
    if own is not None:
        light = scene_light(own.lighting, own.sun.azimuth_deg, own.sun.elevation_deg)
    else:
        sun = resolve_sun(world.spec.appearance.lighting, world.seed)
        light = scene_light(world.spec.appearance.lighting, sun.azimuth_deg, sun.elevation_deg)
    return SceneLooks(instances, asym, light)


def table_looks(world: World, robots: Sequence[tuple[str, str | None]], seed: int) -> TableLooks:
    """The looks an exported object table carries: the world's (``looks``) and each robot's light
    (``lights``: robot -> (sun azimuth, elevation, share)), for ``sequence_looks`` to read back."""
    base = robot_looks(world, "", None, seed)
    assert base is not None  # a World always has looks
    lights: dict[str, tuple[float, float, float]] = {}
    for name, preset in robots:
        own = robot_looks(world, name, preset, seed)
        if own is not None and own.light is not None:
            lights[name] = (own.light.sun_azimuth, own.light.sun_elevation, own.light.sun_share)
    return TableLooks(LooksRecord.of(replace(base, light=None)), lights)


def sequence_looks(table: str | Path, robot: str) -> SceneLooks | None:
    """The looks an exported object table (``objects.json``) carries for ``robot`` (None without them)."""
    doc = read_objects_json(table)
    if doc.looks is None:
        return None
    light = (doc.lights or {}).get(robot)
    return replace(doc.looks.looks(), light=None if light is None else SceneLight(*(float(x) for x in light)))
