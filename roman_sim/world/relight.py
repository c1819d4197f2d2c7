"""A robot's own lighting: the sun, ambient, headlight and sky of a lighting preset put into a
renderer's MuJoCo scene in place of the world's (time of day per robot).

Light changes only the RGB image: depth and object ids come from geometry. The scene's sun
and headlight are overwritten after ``mjv_updateScene`` with exactly the values the world
itself would have compiled for that lighting (``mjcf.sun_light``), and the skybox texture is
re-uploaded to the renderer's OpenGL context from a one-texture spec built by the same
``mjcf.add_sky``; the model is left as it was. A robot's lighting in a world rendered with
that same lighting is therefore byte-identical to the world's own.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from roman_sim.world.appearance import LIGHTING, LightingSpec, Sun, resolve_sun
from roman_sim.world.mjcf import SKY, SUN, add_sky, sun_light


@dataclass(frozen=True)
class RobotLighting:
    """A robot's resolved lighting: the preset, its fields and its sun angles."""

    preset: str
    lighting: LightingSpec
    sun: Sun


def robot_lighting(preset: str | None, seed: int, robot: str) -> RobotLighting | None:
    """The lighting of robot ``robot`` (None: the world's own).

    A preset's ``null`` sun angles (``random``) are drawn from ``child_rng(seed, "lighting",
    robot)``, so two robots with ``random`` see different suns.
    """
    if preset is None:
        return None
    light = LIGHTING.get(preset)
    return RobotLighting(preset, light, resolve_sun(light, seed, "lighting", robot))


def _sky_data(light: LightingSpec) -> np.ndarray:
    """The skybox texels MuJoCo compiles for ``light`` (its builtin gradient)."""
    mjs = mujoco.MjSpec()
    add_sky(mjs, light)
    return np.asarray(mjs.compile().tex_data).copy()


def apply_lighting(
    model: mujoco.MjModel, scene: mujoco.MjvScene, context: mujoco.MjrContext, lit: RobotLighting
) -> None:
    """Put ``lit`` into ``scene`` (built by ``mjv_updateScene``) and ``context`` (its OpenGL textures)."""
    sun_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_LIGHT, SUN)
    sun = sun_light(lit.lighting, lit.sun, float(model.stat.extent))
    for i in range(scene.nlight):
        light = scene.lights[i]
        if light.headlight:
            light.ambient[:] = [lit.lighting.ambient] * 3
            light.diffuse[:] = [lit.lighting.headlight] * 3
        elif light.id == sun_id:
            light.dir[:], light.pos[:], light.diffuse[:] = sun["dir"], sun["pos"], sun["diffuse"]
    sky = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, SKY)
    if sky < 0:
        return
    adr, size = int(model.tex_adr[sky]), int(model.tex_width[sky] * model.tex_height[sky] * model.tex_nchannel[sky])
    own = model.tex_data[adr : adr + size].copy()
    model.tex_data[adr : adr + size] = _sky_data(lit.lighting)[:size]
    try:
        mujoco.mjr_uploadTexture(model, context, sky)
    finally:
        model.tex_data[adr : adr + size] = own
