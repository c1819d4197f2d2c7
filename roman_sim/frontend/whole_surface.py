"""A counterfactual of the simulator: observations made of their objects' whole surfaces.

A forward camera sees the side of an object that faces it, so a segment's centroid, extent
and shape follow the viewing direction: a robot driving the other way sees the other side.
With ``mapping.whole_surface`` the maps stage replaces each observation's points (the
back-projected depth of its mask) by points sampled evenly over the whole surface of the
objects under the mask (every object with at least ``min_share`` of the mask's labelled
points), moved into the robot's odometry frame through the frame's drifted pose. Which
objects are seen, when, by which mask, and with which descriptor is unchanged: only the
part of each object that the points cover stops depending on the view. Masks on terrain
alone (spurious ones) keep their points.

This reads the world's truth, so it exists only for simulated frames; the mapping layer
takes it as ``Mapper``'s ``reshape`` hook and never sees the world. The objects' meshes come
from anything that gives them in the world frame (``HasObjectMeshes``: a generated world),
so this module imports no world.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import transform_points
from roman_sim.core.sensors import Frame
from roman_sim.mapping.tracker import Observation
from roman_sim.mapping.voxels import downsample

if TYPE_CHECKING:
    import trimesh

log = logging.getLogger(__name__)

#: Surface samples per voxel face area (before voxel downsampling), and the bounds per object.
_SAMPLES_PER_CELL = 4.0
_MIN_SAMPLES, _MAX_SAMPLES = 200, 40000


def sample_surface(mesh: trimesh.Trimesh, voxel: float, seed: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points spread evenly over ``mesh`` (about ``_SAMPLES_PER_CELL`` per voxel face, within bounds; seeded)
    and the outward unit normals of the faces they lie on (trimesh's area-weighted sampling)."""
    import trimesh

    n = int(np.clip(_SAMPLES_PER_CELL * mesh.area / voxel**2, _MIN_SAMPLES, _MAX_SAMPLES))
    pts, faces = trimesh.sample.sample_surface(mesh, n, seed=seed)
    return np.asarray(pts, dtype=np.float64), np.asarray(mesh.face_normals[faces], dtype=np.float64)


def objects_under(obs: Observation, min_share: float) -> list[int]:
    """The objects under an observation: ids with at least ``min_share`` of its labelled object points."""
    total = sum(c for i, c in obs.truth.items() if i >= 0)
    return sorted(int(i) for i, c in obs.truth.items() if i >= 0 and c >= min_share * total > 0)


class HasObjectMeshes(Protocol):
    """What the counterfactual needs of a world: each object's mesh in the world frame."""

    def object_mesh_world(self, obj_id: int) -> trimesh.Trimesh:
        """The mesh of object ``obj_id``, placed in the world frame."""
        ...


class WholeSurface:
    """``reshape(frame, observations)``: each observation's points from its objects' whole surfaces.

    Args:
        world: the generated world (its object meshes).
        voxel: the mapping voxel size (m); surfaces are sampled at about this spacing.
        min_share: share of an observation's labelled points an object needs to count as under it.
    """

    def __init__(self, world: HasObjectMeshes, voxel: float, min_share: float = 0.2) -> None:
        self.world = world
        self.voxel = float(voxel)
        self.min_share = float(min_share)
        self._surfaces: dict[int, NDArray[np.float64]] = {}

    def surface(self, oid: int) -> NDArray[np.float64]:
        """(N, 3) world-frame points spread over object ``oid``'s whole surface, voxel-downsampled."""
        if oid not in self._surfaces:
            pts, _ = sample_surface(self.world.object_mesh_world(oid), self.voxel, oid)
            self._surfaces[oid] = downsample(pts, self.voxel)
        return self._surfaces[oid]

    def __call__(self, frame: Frame, observations: list[Observation]) -> list[Observation]:
        if frame.truth is None:
            raise ConfigError(
                f"mapping.whole_surface: frame {frame.index} of robot {frame.robot} has no ground truth "
                "(the counterfactual needs simulated frames; allowed here: false)"
            )
        T_world_cam = np.asarray(frame.truth.T_world_body) @ np.asarray(frame.T_body_cam)
        T_odom_world = frame.T_odom_cam @ np.linalg.inv(T_world_cam)
        out = []
        for obs in observations:
            ids = objects_under(obs, self.min_share)
            if not ids:
                out.append(obs)
                continue
            pts = np.vstack([self.surface(i) for i in ids])
            out.append(replace(obs, points=downsample(transform_points(T_odom_world, pts), self.voxel)))
        return out


def whole_surface_for(world: HasObjectMeshes | None, voxel: float, robot: str) -> WholeSurface:
    """The counterfactual's hook for a simulated robot (``ConfigError`` without a world)."""
    if world is None:
        raise ConfigError(
            f"mapping.whole_surface: robot {robot} is read from a sequence, not simulated; the counterfactual "
            "needs the world's objects (allowed here: false)"
        )
    return WholeSurface(world, voxel)
