"""An independent second depth renderer (pyrender over the world's meshes) for cross-checks.

Rendering the same world from the same camera with MuJoCo (``SensorRenderer``) and with
pyrender over the trimesh objects plus a triangulated terrain catches frame, intrinsics
and export bugs: the two depth images must agree.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np
import trimesh
from numpy.typing import NDArray

from roman_sim.core.glrender import offscreen_renderer
from roman_sim.core.sensors import Intrinsics
from roman_sim.world.truth import Terrain

if TYPE_CHECKING:
    from roman_sim.world import World

log = logging.getLogger(__name__)

#: OpenGL camera (x right, y up, z back) expressed in the RDF optical frame.
_T_RDF_GL = np.diag([1.0, -1.0, -1.0, 1.0])

#: pyrender renders offscreen with 4x multisampling and its depth read-back takes one
#: sample, which in Mesa's standard 4x pattern sits at (0.375, 0.125) of the pixel
#: (window coordinates, y up): (-0.125, +0.375) px from the centre in image (u right,
#: v down) coordinates. The principal point is shifted by this so rays hit pixel centres.
MSAA_SAMPLE_OFFSET_PX = (-0.125, 0.375)


def terrain_mesh(terrain: Terrain) -> trimesh.Trimesh:
    """The heightfield as a triangle mesh (two triangles per grid cell)."""
    rows, cols = terrain.heights.shape
    xs = np.linspace(-terrain.size_x / 2, terrain.size_x / 2, cols)
    ys = np.linspace(-terrain.size_y / 2, terrain.size_y / 2, rows)
    gx, gy = np.meshgrid(xs, ys)
    verts = np.column_stack([gx.ravel(), gy.ravel(), terrain.heights.ravel()])
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    return trimesh.Trimesh(verts, faces, process=False)


def world_meshes(world: World) -> list[trimesh.Trimesh]:
    """World-frame meshes of every object plus the terrain."""
    meshes = [world.object_mesh_world(o.id) for o in world.truth.objects]
    return meshes + [terrain_mesh(world.truth.terrain)]


def pyrender_depth(
    meshes: list[trimesh.Trimesh],
    intrinsics: Intrinsics,
    T_world_cam: NDArray[np.float64],
    near_m: float = 0.05,
    far_m: float = 100.0,
) -> NDArray[np.float32]:
    """Depth (H, W) along the optical axis of ``meshes`` seen from an RDF camera pose (0 = nothing)."""
    import pyrender  # imported here: it creates an OpenGL platform on import

    scene = pyrender.Scene(bg_color=[0, 0, 0, 0], ambient_light=[1.0, 1.0, 1.0])
    for m in meshes:
        scene.add(pyrender.Mesh.from_trimesh(m, smooth=False))
    k = intrinsics
    # pyrender's principal point is in window coordinates (pixel edges), ours at pixel centres.
    du, dv = MSAA_SAMPLE_OFFSET_PX
    cam = pyrender.IntrinsicsCamera(k.fx, k.fy, k.cx + 0.5 + du, k.cy + 0.5 + dv, znear=near_m, zfar=far_m)
    scene.add(cam, pose=np.asarray(T_world_cam, dtype=np.float64) @ _T_RDF_GL)
    depth = offscreen_renderer(k.width, k.height).render(scene, flags=pyrender.RenderFlags.DEPTH_ONLY)
    return np.asarray(depth, dtype=np.float32)
