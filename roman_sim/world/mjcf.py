"""MjSpec construction: visual settings, the sun, the sky, the terrain hfield, object geoms and
their materials (``roman_sim.world.appearance`` says what each setting does)."""

from __future__ import annotations

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
    instance_draws,
    vary_rgba,
)
from roman_sim.world.assets import Part
from roman_sim.world.catalog import Asset
from roman_sim.world.spec import WorldSpec
from roman_sim.world.terrain import hfield_data
from roman_sim.world.textures import SURFACES, TEXTURE_MEAN, box_uv, instance_uv, texture_image
from roman_sim.world.truth import ObjectTruth, Terrain

OFF_WIDTH, OFF_HEIGHT = 1280, 960
TERRAIN_GEOM = "terrain"
GROUND = "ground"
NEAR_CLIP_M = 0.05
SUN = "sun"
SKY = "sky"
MATERIAL_PREFIX = "surf_"  # material (and texture) of each surface kind: surf_bark, surf_rock, ...
INSTANCE_MESH_SEP = "@"  # an instance's own mesh copy: conifer_v0_s1_crown@12 (object 12)


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
    """Surface materials and textures of a world (one each per surface kind), and the instances'
    colours and texture coordinates.

    With ``texture_scope: instance`` a kind's texture is an atlas of ``atlas_tiles`` x
    ``atlas_tiles`` tiles and every object part looks at its own region of it (``instance_uv``,
    drawn from ``child_rng(seed, "world", "appearance", "texture", object_id, part_index)``)
    through its own copy of the mesh; with ``surface`` the texture is one tile that every
    instance shows alike. A kind's texture is drawn from ``child_rng(seed, ..., "texture", kind)``.
    """

    spec: AppearanceSpec
    seed: int
    added: set[str] = field(default_factory=set)

    @property
    def per_instance(self) -> bool:
        """Whether every object part has its own texture coordinates (and mesh copy)."""
        return self.spec.textures and self.spec.texture_scope == "instance"

    def material(self, mjs: mujoco.MjSpec, kind: str) -> str:
        """Name of the material of surface ``kind`` (created on first use)."""
        name = f"{MATERIAL_PREFIX}{kind}"
        if name in self.added:
            return name
        surface = SURFACES.get(kind)
        # MuJoCo takes a geom's rgba only when it differs from the default grey, else the
        # material's: the material is that grey too, so every instance shows its own colour
        mat = mjs.add_material(
            name=name, specular=surface.specular, shininess=surface.shininess, rgba=[0.5, 0.5, 0.5, 1.0]
        )
        if self.spec.textures:
            n = self.spec.texture_side_px()
            rng = child_rng(self.seed, "world", "appearance", "texture", kind)
            img = texture_image(kind, rng, n, self.spec.texture_px)
            tex = mjs.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=n, height=n, nchannel=3)
            tex.data = img.tobytes()
            mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name
        self.added.add(name)
        return name

    def uv(self, part: Part, obj_id: int, k: int) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
        """Texture coordinates (3F, 2) of part ``k`` of object ``obj_id`` and their face indices (3F,)."""
        uv, idx = box_uv(part.mesh, SURFACES.get(part.surface).tile_m, part.grain_axis)
        if self.per_instance:
            rng = child_rng(self.seed, "world", "appearance", "texture", obj_id, k)
            uv = instance_uv(uv, part.surface, self.spec.atlas_tiles, rng)
        return uv, idx

    def rgba(self, part: Part, draws: NDArray[np.float64]) -> NDArray[np.float64]:
        """The instance colour of ``part`` (brightened to offset the texture's mean when textured)."""
        var = part.variation or SURFACES.get(part.surface).variation
        rgba = vary_rgba(part.rgba, var, self.spec.instance_variation, draws)
        if self.spec.textures and rgba[:3].max() > 0:
            rgba[:3] *= min(1.0 / TEXTURE_MEAN, 1.0 / rgba[:3].max())  # same hue, saturation
        return rgba


def instance_mesh_name(shape: str, obj_id: int) -> str:
    """MuJoCo mesh name of object ``obj_id``'s own copy of mesh ``shape``."""
    return f"{shape}{INSTANCE_MESH_SEP}{obj_id}"


def shape_of(mesh_name: str) -> str:
    """The shape (``World.meshes`` key) of a MuJoCo mesh name (an instance copy's or a shared one)."""
    return mesh_name.split(INSTANCE_MESH_SEP, 1)[0]


def _add_mesh(mjs: mujoco.MjSpec, name: str, part: Part, uv: tuple[NDArray, NDArray] | None) -> None:
    m = mjs.add_mesh(name=name)
    m.uservert = np.asarray(part.mesh.vertices, dtype=np.float32).ravel().tolist()
    m.userface = np.asarray(part.mesh.faces, dtype=np.int32).ravel().tolist()
    if uv is not None:
        m.usertexcoord = uv[0].ravel().tolist()
        m.userfacetexcoord = uv[1].tolist()


def add_object_geoms(
    mjs: mujoco.MjSpec, obj: ObjectTruth, asset: Asset, meshes: dict[str, trimesh.Trimesh], looks: Looks
) -> None:
    """Add one static mesh geom per part of ``obj`` (named ``obj{id}_{k}``) with its material.

    Untextured or with one texture per surface kind, instances share one MuJoCo mesh per
    shape; with per-instance textures every part has its own copy (``instance_mesh_name``),
    which differs only in its texture coordinates. ``meshes`` collects the shapes.
    """
    pos = obj.T_world_obj[:3, 3]
    yaw = float(np.arctan2(obj.T_world_obj[1, 0], obj.T_world_obj[0, 0]))
    quat = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    draws = instance_draws(looks.seed, obj.id, len(asset.parts))
    for k, part in enumerate(asset.parts):
        shape = asset.mesh_name(part)
        name = instance_mesh_name(shape, obj.id) if looks.per_instance else shape
        if shape not in meshes or looks.per_instance:
            meshes[shape] = part.mesh
            _add_mesh(mjs, name, part, looks.uv(part, obj.id, k) if looks.spec.textures else None)
        mjs.worldbody.add_geom(
            name=f"obj{obj.id}_{k}",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=name,
            pos=pos.tolist(),
            quat=quat,
            rgba=looks.rgba(part, draws[k]).tolist(),
            material=looks.material(mjs, part.surface),
        )
