"""Shared fixtures for the sim tests: a tiny hand-built MuJoCo world with known geometry."""

from __future__ import annotations

from dataclasses import dataclass

# isort: off
import roman_sim  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco

# isort: on
import numpy as np
import pytest

from roman_sim.core.geometry import make_T
from roman_sim.world.truth import ObjectTruth, Terrain, WorldTruth

BOX_CENTER = np.array([5.0, 0.0, 0.5])
BOX_HALF = np.array([0.5, 0.5, 0.5])


@dataclass
class FixtureWorld:
    """Minimal stand-in for ``roman_sim.world.World``: a ground plane and one box."""

    model: mujoco.MjModel
    truth: WorldTruth


def build_plane_box_world() -> FixtureWorld:
    """Ground plane z = 0 (background) and a 1 m cube centred at BOX_CENTER (object 0)."""
    spec = mujoco.MjSpec()
    spec.visual.global_.offwidth = 320
    spec.visual.global_.offheight = 240
    spec.visual.quality.shadowsize = 0
    body = spec.worldbody
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1], rgba=[0.3, 0.5, 0.3, 1])
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=BOX_HALF, pos=BOX_CENTER, rgba=[0.8, 0.2, 0.2, 1])
    body.add_light(type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, dir=[0, 0, -1], pos=[0, 0, 10])
    model = spec.compile()
    T = make_T(t=BOX_CENTER - [0, 0, 0.5])
    obj = ObjectTruth(
        id=0,
        family="box",
        T_world_obj=T,
        extents=2 * BOX_HALF,
        volume=1.0,
        centroid=BOX_CENTER.copy(),
        geom_ids=[1],
        mesh_names=[],
        obb_T_world=make_T(t=BOX_CENTER),
        obb_extents=2 * BOX_HALF,
        radius=0.71,
    )
    terrain = Terrain(size_x=40.0, size_y=40.0, heights=np.zeros((5, 5)))
    return FixtureWorld(model=model, truth=WorldTruth(objects=[obj], terrain=terrain))


@pytest.fixture(scope="session")
def plane_box_world() -> FixtureWorld:
    return build_plane_box_world()


@pytest.fixture(scope="session")
def tiny_world():
    """The ``tiny`` preset world (seed 0)."""
    from roman_sim.world import generate, load_world_spec

    return generate(load_world_spec("tiny"), 0)
