"""MjSpec construction: visual settings, lights, the terrain hfield and object geoms."""

from __future__ import annotations

import mujoco
import numpy as np
import trimesh
from numpy.typing import NDArray

from roman_sim.world.catalog import Asset
from roman_sim.world.spec import WorldSpec
from roman_sim.world.terrain import hfield_data
from roman_sim.world.truth import ObjectTruth, Terrain

OFF_WIDTH, OFF_HEIGHT = 1280, 960
TERRAIN_GEOM = "terrain"
GROUND = "ground"
NEAR_CLIP_M = 0.05
COLOUR_JITTER = 0.12  # relative per-instance brightness jitter


def _visuals(mjs: mujoco.MjSpec, spec: WorldSpec) -> None:
    mjs.visual.global_.offwidth = OFF_WIDTH
    mjs.visual.global_.offheight = OFF_HEIGHT
    mjs.visual.quality.shadowsize = 0  # shadows cost ~5x in software rendering
    mjs.visual.headlight.ambient = [0.35, 0.35, 0.35]
    mjs.visual.headlight.diffuse = [0.35, 0.35, 0.35]
    mjs.stat.extent = float(max(spec.extent_m)) / 2
    # clip planes are relative to stat.extent: 5 cm near plane, far plane past the world
    mjs.visual.map.znear = NEAR_CLIP_M / mjs.stat.extent
    mjs.visual.map.zfar = 2.0 * max(spec.extent_m) / mjs.stat.extent
    mjs.stat.center = [0.0, 0.0, 0.0]
    mjs.worldbody.add_light(
        name="sun",
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
        dir=[0.3, 0.2, -1.0],
        pos=[0.0, 0.0, 100.0],
        diffuse=[0.7, 0.7, 0.65],
        ambient=[0.15, 0.15, 0.15],
        castshadow=False,
    )


def _sky(mjs: mujoco.MjSpec) -> None:
    mjs.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                    width=64, height=64, rgb1=[0.55, 0.7, 0.9], rgb2=[0.9, 0.93, 0.97])


def add_terrain(mjs: mujoco.MjSpec, terrain: Terrain, base_z: float, elevation: float, ground: NDArray[np.uint8]) -> None:
    """Add the hfield geom (geom 0) that reproduces ``terrain`` exactly, textured with ``ground``."""
    rows, cols = terrain.shape
    tex = mjs.add_texture(name=GROUND, type=mujoco.mjtTexture.mjTEXTURE_2D, width=ground.shape[1], height=ground.shape[0], nchannel=3)
    tex.data = np.ascontiguousarray(ground).tobytes()
    mat = mjs.add_material(name=GROUND)
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex.name
    mat.texrepeat = [1.0, 1.0]  # the image covers the hfield once (roads line up with truth)
    depth = max(1.0, 0.1 * elevation)
    mjs.add_hfield(name="terrain", size=[terrain.size_x / 2, terrain.size_y / 2, elevation, depth],
                   nrow=rows, ncol=cols, userdata=hfield_data(terrain, base_z, elevation).ravel().tolist())
    mjs.worldbody.add_geom(name=TERRAIN_GEOM, type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain",
                           pos=[0.0, 0.0, base_z], material=GROUND)


def new_spec(spec: WorldSpec, terrain: Terrain, base_z: float, elevation: float, ground: NDArray[np.uint8]) -> mujoco.MjSpec:
    """An MjSpec holding the visuals, the sun and the terrain of a world."""
    mjs = mujoco.MjSpec()
    mjs.modelname = spec.name
    mjs.compiler.degree = False
    _visuals(mjs, spec)
    _sky(mjs)
    add_terrain(mjs, terrain, base_z, elevation, ground)
    return mjs


def _add_mesh(mjs: mujoco.MjSpec, name: str, mesh: trimesh.Trimesh) -> None:
    m = mjs.add_mesh(name=name)
    m.uservert = np.asarray(mesh.vertices, dtype=np.float32).ravel().tolist()
    m.userface = np.asarray(mesh.faces, dtype=np.int32).ravel().tolist()


def add_object_geoms(mjs: mujoco.MjSpec, obj: ObjectTruth, asset: Asset, meshes: dict[str, trimesh.Trimesh], rng: np.random.Generator) -> None:
    """Add one static mesh geom per part of ``obj`` (named ``obj{id}_{k}``), sharing meshes."""
    pos = obj.T_world_obj[:3, 3]
    yaw = float(np.arctan2(obj.T_world_obj[1, 0], obj.T_world_obj[0, 0]))
    quat = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
    for k, part in enumerate(asset.parts):
        name = asset.mesh_name(part)
        if name not in meshes:
            meshes[name] = part.mesh
            _add_mesh(mjs, name, part.mesh)
        gain = 1.0 + COLOUR_JITTER * rng.uniform(-1.0, 1.0)
        rgba = np.clip(np.array(part.rgba) * [gain, gain, gain, 1.0], 0.0, 1.0)
        mjs.worldbody.add_geom(name=f"obj{obj.id}_{k}", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name,
                               pos=pos.tolist(), quat=quat, rgba=rgba.tolist())
