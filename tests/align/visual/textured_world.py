"""A tiny textured world for the visual tests: a textured ground and eight two-faced panels.

Each panel stands 6 m from the origin, facing it, and is two thin boxes back to back with
their own blob-noise textures: a panel looks different from the front (the origin side)
and from behind. Textures are seeded, so every run renders the same images.
"""

from __future__ import annotations

from dataclasses import dataclass

# isort: off
import roman_sim  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco

# isort: on
import cv2
import numpy as np

from roman_sim.core.geometry import R_FLU_RDF, make_T, rot_z
from roman_sim.core.seeding import child_rng
from roman_sim.world.truth import Terrain, WorldTruth

N_PANELS = 8
PANEL_RADIUS_M = 6.0
CAM_HEIGHT_M = 1.0


@dataclass
class TexturedWorld:
    """Stand-in for ``roman_sim.world.World`` (``model`` and ``truth`` are what the renderer reads)."""

    model: mujoco.MjModel
    truth: WorldTruth


def blob_texture(rng: np.random.Generator, size: int = 256, shapes: int = 60) -> np.ndarray:
    """(size, size, 3) uint8 texture: smooth colour noise under random filled discs and rectangles."""
    img = np.zeros((size, size, 3))
    for cells, amp in ((6, 1.0), (16, 0.6)):
        small = rng.random((cells, cells, 3))
        img += amp * cv2.resize(small, (size, size), interpolation=cv2.INTER_CUBIC)
    img = (255 * (img - img.min()) / (img.max() - img.min())).astype(np.uint8)
    for _ in range(shapes):
        colour = tuple(int(c) for c in rng.integers(0, 256, 3))
        x, y = (int(v) for v in rng.integers(0, size, 2))
        r = int(rng.integers(size // 40, size // 10))
        if rng.random() < 0.5:
            cv2.circle(img, (x, y), r, colour, -1)
        else:
            cv2.rectangle(img, (x - r, y - r // 2), (x + r, y + r // 2), colour, -1)
    return img


def _texture(spec: mujoco.MjSpec, name: str, img: np.ndarray, repeat: float = 1.0) -> str:
    tex = spec.add_texture(
        name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=img.shape[1], height=img.shape[0], nchannel=3
    )
    tex.data = np.ascontiguousarray(img).tobytes()
    mat = spec.add_material(name=name)
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name
    mat.texrepeat = [repeat, repeat]
    return name


def build_textured_world(seed: int = 0, size_px: int = 320) -> TexturedWorld:
    """The ground plane and the panels (see the module docstring)."""
    spec = mujoco.MjSpec()
    spec.visual.global_.offwidth = size_px
    spec.visual.global_.offheight = size_px
    spec.visual.quality.shadowsize = 0
    spec.visual.headlight.ambient = [0.6, 0.6, 0.6]
    spec.visual.headlight.diffuse = [0.3, 0.3, 0.3]
    body = spec.worldbody
    ground = _texture(spec, "ground", blob_texture(child_rng(seed, "tex", "ground"), 1024, 600), repeat=1.0)
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1], material=ground)
    for i in range(N_PANELS):
        yaw = 2 * np.pi * i / N_PANELS
        for side, offset in (("front", -0.05), ("back", 0.05)):
            mat = _texture(spec, f"p{i}{side}", blob_texture(child_rng(seed, "tex", i, side)))
            r = PANEL_RADIUS_M + offset
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, rot_z(yaw).ravel())
            pos = [r * np.cos(yaw), r * np.sin(yaw), 1.2]
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 1.5, 1.2], pos=pos, quat=quat, material=mat)
    body.add_light(type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, dir=[0.3, 0.2, -1], pos=[0, 0, 10])
    terrain = Terrain(size_x=40.0, size_y=40.0, heights=np.zeros((5, 5)))
    return TexturedWorld(spec.compile(), WorldTruth(objects=[], terrain=terrain))


def camera_pose(x: float, y: float, yaw: float, z: float = CAM_HEIGHT_M) -> np.ndarray:
    """Level camera (RDF) at (x, y, z) looking along heading ``yaw`` (rad)."""
    return make_T(rot_z(yaw) @ R_FLU_RDF, [x, y, z])
