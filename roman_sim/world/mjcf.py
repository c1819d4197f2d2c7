"""MjSpec construction: visual settings, the sun, the sky, the terrain hfield, object geoms and
their materials (``roman_sim.world.appearance`` says what each setting does)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np
import trimesh
from numpy.typing import NDArray

from roman_sim.core.seeding import child_rng
from roman_sim.world.appearance import (
    AppearanceSpec,
    LightingSpec,
    Sun,
    check_texture_memory,
    instance_draws,
    vary_rgba,
)
from roman_sim.world.assets import Part
from roman_sim.world.catalog import Asset
from roman_sim.world.spec import WorldSpec
from roman_sim.world.terrain import hfield_data
from roman_sim.world.textures import BATCH, SURFACES, TEXTURE_MEAN, box_uv, texture_image, texture_images
from roman_sim.world.truth import ObjectTruth, Terrain

OFF_WIDTH, OFF_HEIGHT = 1280, 960
TERRAIN_GEOM = "terrain"
GROUND = "ground"
NEAR_CLIP_M = 0.05
SUN = "sun"
SKY = "sky"
MATERIAL_PREFIX = "surf_"  # materials and textures: surf_bark (shared), surf_bark_12_0 (object 12, part 0)


def _visuals(mjs: mujoco.MjSpec, spec: WorldSpec, sun: Sun) -> None:
    app, light = spec.appearance, spec.appearance.lighting
    mjs.visual.global_.offwidth = OFF_WIDTH
    mjs.visual.global_.offheight = OFF_HEIGHT
    mjs.visual.quality.shadowsize = app.shadow_px if app.shadows else 0  # shadows cost ~5x in software
    mjs.visual.headlight.ambient = [light.ambient] * 3
    mjs.visual.headlight.diffuse = [light.headlight] * 3
    mjs.stat.extent = float(max(spec.extent_m)) / 2
    # clip planes are relative to stat.extent: 5 cm near plane, far plane past the world
    mjs.visual.map.znear = NEAR_CLIP_M / mjs.stat.extent
    mjs.visual.map.zfar = 2.0 * max(spec.extent_m) / mjs.stat.extent
    mjs.stat.center = [0.0, 0.0, 0.0]
    mjs.worldbody.add_light(
        name=SUN,
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
        ambient=[0.0, 0.0, 0.0],
        castshadow=app.shadows,
        **sun_light(light, sun, mjs.stat.extent),
    )


def sun_light(light: LightingSpec, sun: Sun, extent: float) -> dict[str, list[float]]:
    """Direction, position and diffuse colour of the sun light in a world of ``stat.extent`` ``extent``.

    A directional light's shadow map is an orthographic view from its position along dir, so
    the sun sits on its own side of the world, one world radius out.
    """
    towards = sun.towards
    return {
        "dir": (-towards).tolist(),
        "pos": (towards * 2.0 * extent).tolist(),
        "diffuse": (light.sun * np.asarray(light.colour)).tolist(),
    }


def add_sky(mjs: mujoco.MjSpec, light: LightingSpec) -> mujoco.MjsTexture:
    """Add the skybox: a gradient from ``light.sky`` at the zenith to a paler horizon."""
    zenith = np.asarray(light.sky)
    horizon = 1.0 - 0.22 * (1.0 - zenith)
    return mjs.add_texture(
        name=SKY,
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        width=64,
        height=64,
        rgb1=zenith.tolist(),
        rgb2=horizon.tolist(),
    )


def add_terrain(
    mjs: mujoco.MjSpec, terrain: Terrain, base_z: float, elevation: float, ground: NDArray[np.uint8]
) -> None:
    """Add the hfield geom (geom 0) that reproduces ``terrain`` exactly, textured with ``ground``."""
    rows, cols = terrain.shape
    tex = mjs.add_texture(
        name=GROUND, type=mujoco.mjtTexture.mjTEXTURE_2D, width=ground.shape[1], height=ground.shape[0], nchannel=3
    )
    tex.data = np.ascontiguousarray(ground).tobytes()
    mat = mjs.add_material(name=GROUND, specular=0.0)  # grass and dirt do not shine
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex.name
    mat.texrepeat = [1.0, 1.0]  # the image covers the hfield once (roads line up with truth)
    depth = max(1.0, 0.1 * elevation)
    mjs.add_hfield(
        name="terrain",
        size=[terrain.size_x / 2, terrain.size_y / 2, elevation, depth],
        nrow=rows,
        ncol=cols,
        userdata=hfield_data(terrain, base_z, elevation).ravel().tolist(),
    )
    mjs.worldbody.add_geom(
        name=TERRAIN_GEOM,
        type=mujoco.mjtGeom.mjGEOM_HFIELD,
        hfieldname="terrain",
        pos=[0.0, 0.0, base_z],
        material=GROUND,
    )


def new_spec(
    spec: WorldSpec, terrain: Terrain, base_z: float, elevation: float, ground: NDArray[np.uint8], sun: Sun
) -> mujoco.MjSpec:
    """An MjSpec holding the visuals, the sun and the terrain of a world."""
    mjs = mujoco.MjSpec()
    mjs.modelname = spec.name
    mjs.compiler.degree = False
    _visuals(mjs, spec, sun)
    add_sky(mjs, spec.appearance.lighting)
    add_terrain(mjs, terrain, base_z, elevation, ground)
    return mjs


@dataclass
class Looks:
    """Materials and textures of a world's object parts, and the instance colours.

    With ``texture_scope: instance`` every object part gets its own material and texture
    realisation, drawn from ``child_rng(seed, "world", "appearance", "texture", object_id,
    part_index)``; with ``surface`` (or without textures) the parts of one surface kind share
    one material (its texture drawn from ``child_rng(seed, ..., "texture", kind)``).
    """

    spec: AppearanceSpec
    seed: int
    added: set[str] = field(default_factory=set)
    own: dict[tuple[int, int], str] = field(default_factory=dict)  # (object id, part index) -> material

    @property
    def per_instance(self) -> bool:
        """Whether every object part has its own texture."""
        return self.spec.textures and self.spec.texture_scope == "instance"

    def _add_material(self, mjs: mujoco.MjSpec, name: str, kind: str, img: NDArray[np.uint8] | None) -> None:
        surface = SURFACES.get(kind)
        # MuJoCo takes a geom's rgba only when it differs from the default grey, else the
        # material's: the material is that grey too, so every instance shows its own colour
        mat = mjs.add_material(
            name=name, specular=surface.specular, shininess=surface.shininess, rgba=[0.5, 0.5, 0.5, 1.0]
        )
        if img is not None:
            tex = mjs.add_texture(
                name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=img.shape[1], height=img.shape[0], nchannel=3
            )
            tex.data = img.tobytes()
            mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name

    def add_instance_textures(self, mjs: mujoco.MjSpec, parts: Sequence[tuple[int, Sequence[Part]]]) -> None:
        """Give every part of every (object id, parts) its own material and texture (instance scope only).

        Textures are drawn per surface kind in batches (``texture_images``), so the arrays
        held at once stay small whatever the world's size.
        """
        if not self.per_instance:
            return
        check_texture_memory(self.spec, sum(len(p) for _, p in parts))
        by_kind: dict[str, list[tuple[int, int]]] = {}
        for obj_id, obj_parts in parts:
            for k, part in enumerate(obj_parts):
                by_kind.setdefault(part.surface, []).append((obj_id, k))
        n = self.spec.texture_px
        for kind in sorted(by_kind):
            keys = by_kind[kind]
            for lo in range(0, len(keys), BATCH):
                batch = keys[lo : lo + BATCH]
                rngs = [child_rng(self.seed, "world", "appearance", "texture", i, k) for i, k in batch]
                for (i, k), img in zip(batch, texture_images(kind, rngs, n)):
                    name = f"{MATERIAL_PREFIX}{kind}_{i}_{k}"
                    self._add_material(mjs, name, kind, img)
                    self.own[(i, k)] = name

    def material(self, mjs: mujoco.MjSpec, part: Part, obj_id: int, k: int) -> str:
        """Name of the material of part ``k`` of object ``obj_id`` (a shared one is created on first use)."""
        if (obj_id, k) in self.own:
            return self.own[(obj_id, k)]
        kind = part.surface
        name = f"{MATERIAL_PREFIX}{kind}"
        if name not in self.added:
            img = None
            if self.spec.textures:
                rng = child_rng(self.seed, "world", "appearance", "texture", kind)
                img = texture_image(kind, rng, self.spec.texture_px)
            self._add_material(mjs, name, kind, img)
            self.added.add(name)
        return name

    def rgba(self, part: Part, draws: NDArray[np.float64]) -> NDArray[np.float64]:
        """The instance colour of ``part`` (brightened to offset the texture's mean when textured)."""
        var = part.variation or SURFACES.get(part.surface).variation
        rgba = vary_rgba(part.rgba, var, self.spec.instance_variation, draws)
        if self.spec.textures and rgba[:3].max() > 0:
            rgba[:3] *= min(1.0 / TEXTURE_MEAN, 1.0 / rgba[:3].max())  # same hue, saturation
        return rgba


def _add_mesh(mjs: mujoco.MjSpec, name: str, part: Part, textured: bool) -> None:
    m = mjs.add_mesh(name=name)
    m.uservert = np.asarray(part.mesh.vertices, dtype=np.float32).ravel().tolist()
    m.userface = np.asarray(part.mesh.faces, dtype=np.int32).ravel().tolist()
    if textured:
        uv, idx = box_uv(part.mesh, SURFACES.get(part.surface).tile_m, part.grain_axis)
        m.usertexcoord = uv.ravel().tolist()
        m.userfacetexcoord = idx.tolist()


def add_object_geoms(
    mjs: mujoco.MjSpec, obj: ObjectTruth, asset: Asset, meshes: dict[str, trimesh.Trimesh], looks: Looks
) -> None:
    """Add one static mesh geom per part of ``obj`` (named ``obj{id}_{k}``), sharing meshes and materials."""
    pos = obj.T_world_obj[:3, 3]
    yaw = float(np.arctan2(obj.T_world_obj[1, 0], obj.T_world_obj[0, 0]))
    quat = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    draws = instance_draws(looks.seed, obj.id, len(asset.parts))
    for k, part in enumerate(asset.parts):
        name = asset.mesh_name(part)
        if name not in meshes:
            meshes[name] = part.mesh
            _add_mesh(mjs, name, part, looks.spec.textures)
        mjs.worldbody.add_geom(
            name=f"obj{obj.id}_{k}",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=name,
            pos=pos.tolist(),
            quat=quat,
            rgba=looks.rgba(part, draws[k]).tolist(),
            material=looks.material(mjs, part, obj.id, k),
        )
