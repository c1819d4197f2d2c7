"""Counterfactuals of the simulator, one per reason a camera misses part of an object.

A segment's points are the back-projected depth of its masks, so they cover only the part of
each object the camera saw: which part follows the viewing direction, which is how heading moves
a segment's centroid, extent and shape. ``mapping.whole_surface`` (``frontend.whole_surface``)
replaces an observation's points by the object's whole surface and so removes every reason at
once. This module splits them. For each observation, points are sampled evenly over the surface of
the objects under its mask (every object with at least ``min_share`` of the mask's labelled
points) and each sample gets the reasons the camera could not have seen it:

- ``back_side``: its surface faces away from the camera, or is hidden by its own object
  (one-sided visibility);
- ``occluded``: it faces the camera inside the image and range, but the depth image shows
  something else nearer at its pixel (by more than ``occlusion_tol_m``; another object or the
  ground, by the instance image);
- ``beyond_range``: it faces the camera inside the image, farther than ``mapping.max_depth_m``
  (range truncation);
- ``out_of_view``: it lies outside the image (behind the camera, or projected off it).

``mapping.complete`` names the reasons switched off: a sample is added to the observation's
points when every reason it has is switched off (a back-side sample beyond the range is added
only when both are), and samples with no reason (seen) are not added, as the depth image already
gives them. The observation's own points stay (with their depth noise: ``camera.depth_noise``
switches that off; the segmenter's view crops are its own switch,
``frontend.segmenter.params.view_split_frac`` and ``partial_frac``). With all four reasons
switched off an observation holds its objects' whole surface plus what the camera measured.
Which objects are seen, when, by which mask, with which descriptor, is unchanged.

This reads the world's truth, so it exists only for simulated frames; the mapping layer takes it
as ``Mapper``'s ``reshape`` hook and never sees the world.
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import transform_points
from roman_sim.core.sensors import Frame, project
from roman_sim.frontend.whole_surface import HasObjectMeshes, objects_under, sample_surface
from roman_sim.mapping.tracker import Observation
from roman_sim.mapping.voxels import downsample

log = logging.getLogger(__name__)

#: The reasons a camera misses part of an object, each a switch of ``mapping.complete``.
REASONS = ("back_side", "occluded", "beyond_range", "out_of_view")


def classify(
    frame: Frame,
    oid: int,
    pts_cam: NDArray[np.float64],
    normals_cam: NDArray[np.float64],
    max_depth_m: float,
    tol_m: float,
) -> dict[str, NDArray[np.bool_]]:
    """Per reason, which camera-frame surface samples of object ``oid`` (with outward normals) the camera
    misses for it. A sample hidden by its own object (the far wheel behind a car's body) counts as turned
    away: that is seeing the object from one side; hidden by anything else (another object, the
    ground) it is occluded."""
    back = np.einsum("ij,ij->i", normals_cam, pts_cam) >= 0.0  # the surface turns away from the ray to it
    uv, front = project(frame.intrinsics.K, pts_cam)
    w, h = frame.intrinsics.width, frame.intrinsics.height
    inside = front.copy()
    inside[front] = (uv[front, 0] >= 0) & (uv[front, 0] < w) & (uv[front, 1] >= 0) & (uv[front, 1] < h)
    z = pts_cam[:, 2]
    beyond = inside & (z > max_depth_m)
    hidden = np.zeros(len(pts_cam), dtype=bool)
    own = np.zeros(len(pts_cam), dtype=bool)
    rows = np.flatnonzero(inside & ~beyond)
    if len(rows):
        u = uv[rows, 0].astype(np.int64)
        v = uv[rows, 1].astype(np.int64)
        d = np.asarray(frame.depth, dtype=np.float64)[v, u]
        hidden[rows] = (d > 0) & np.isfinite(d) & (d < z[rows] - tol_m)
        if frame.truth is not None and frame.truth.object_ids is not None:
            own[rows] = np.asarray(frame.truth.object_ids)[v, u] == oid
    back = back | (hidden & own)
    return {
        "back_side": back,
        "occluded": hidden & ~own & ~back,
        "beyond_range": beyond & ~back,
        "out_of_view": ~inside,
    }


class SurfaceCompletion:
    """``reshape(frame, observations)``: each observation's points plus its objects' samples missed only
    for the switched-off reasons.

    Args:
        world: the generated world (its object meshes).
        voxel: the mapping voxel size (m); surfaces are sampled at about this spacing.
        max_depth_m: the mapping's depth range (``mapping.max_depth_m``).
        switched_off: the reasons whose misses are filled in (a subset of ``REASONS``).
        min_share: share of an observation's labelled points an object needs to count as under it.
        occlusion_tol_m: how much nearer the depth image must be than a sample to occlude it.
    """

    def __init__(
        self,
        world: HasObjectMeshes,
        voxel: float,
        max_depth_m: float,
        switched_off: list[str],
        min_share: float = 0.2,
        occlusion_tol_m: float = 0.1,
    ) -> None:
        unknown = sorted(set(switched_off) - set(REASONS))
        if unknown:
            raise ConfigError(f"mapping.complete: unknown reason {unknown[0]!r} (allowed: {', '.join(REASONS)})")
        self.world = world
        self.voxel = float(voxel)
        self.max_depth_m = float(max_depth_m)
        self.off = frozenset(switched_off)
        self.min_share = float(min_share)
        self.tol = float(occlusion_tol_m)
        self._samples: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

    def samples(self, oid: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World-frame surface samples of object ``oid`` and their outward unit normals."""
        if oid not in self._samples:
            self._samples[oid] = sample_surface(self.world.object_mesh_world(oid), self.voxel, oid)
        return self._samples[oid]

    def missed(self, frame: Frame, oid: int, T_cam_world: NDArray[np.float64] | None = None) -> NDArray[np.bool_]:
        """Which samples of object ``oid`` this frame misses for switched-off reasons only (``T_cam_world``: the
        frame's true camera pose inverted, derived from the frame when not given)."""
        pts, nrm = self.samples(oid)
        T = _T_cam_world(frame) if T_cam_world is None else T_cam_world
        pc = transform_points(T, pts)
        nc = nrm @ T[:3, :3].T
        why = classify(frame, oid, pc, nc, self.max_depth_m, self.tol)
        any_reason = np.zeros(len(pts), dtype=bool)
        blocked = np.zeros(len(pts), dtype=bool)
        for reason, hit in why.items():
            any_reason |= hit
            if reason not in self.off:
                blocked |= hit
        return any_reason & ~blocked

    def __call__(self, frame: Frame, observations: list[Observation]) -> list[Observation]:
        if frame.truth is None:
            raise ConfigError(
                f"mapping.complete: frame {frame.index} of robot {frame.robot} has no ground truth "
                "(the counterfactual needs simulated frames; allowed here: [])"
            )
        if not self.off:
            return observations
        T_cam_world = _T_cam_world(frame)
        T_odom_world = frame.T_odom_cam @ T_cam_world
        out = []
        for obs in observations:
            ids = objects_under(obs, self.min_share)
            added = [self.samples(i)[0][self.missed(frame, i, T_cam_world)] for i in ids]
            added = [a for a in added if len(a)]
            if not added:
                out.append(obs)
                continue
            extra = transform_points(T_odom_world, np.vstack(added))
            out.append(replace(obs, points=downsample(np.vstack([obs.points, extra]), self.voxel)))
        return out


def _T_cam_world(frame: Frame) -> NDArray[np.float64]:
    """The inverse of the frame's true camera pose (the caller has checked that the frame carries truth)."""
    assert frame.truth is not None
    return np.asarray(np.linalg.inv(np.asarray(frame.truth.T_world_body) @ np.asarray(frame.T_body_cam)), np.float64)


def surface_completion_for(
    world: HasObjectMeshes | None, voxel: float, max_depth_m: float, switched_off: list[str], robot: str
) -> SurfaceCompletion:
    """The counterfactual's hook for a simulated robot (``ConfigError`` without a world)."""
    if world is None:
        raise ConfigError(
            f"mapping.complete: robot {robot} is read from a sequence, not simulated; the counterfactual needs the "
            "world's objects (allowed here: [])"
        )
    return SurfaceCompletion(world, voxel, max_depth_m, switched_off)
