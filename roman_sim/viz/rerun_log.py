"""Log the parts of a run into a rerun recording (one function per part).

Entity tree (``r`` a robot, ``k`` a submap index)::

    world/terrain                      Mesh3D (static)
    world/objects                      Boxes3D, one per object, class = family (static)
    world/trajectories/r/<variant>     LineStrips3D: truth, odometry, <method>, oracle (static)
    world/maps/r                       Transform3D: the robot's odometry frame in the world
    world/maps/r/points, /centroids    Points3D: segment points (class = segment id), centroids
    world/submaps/r/k                  Transform3D: the submap's true gravity-aligned pose
    world/submaps/r/k/segments         Points3D: the submap's segment centres (submap frame)
    world/loop_closures/<verdict>      LineStrips3D between true submap centres: correct,
                                       wrong (both kept by the pose graph), rejected (by GNC)
    world/robots/r/camera              Transform3D + Pinhole (RDF): the camera on the timeline
    world/robots/r/camera/rgb, depth, mask   Image, DepthImage, SegmentationImage (id + 1)

Timelines: ``time`` (seconds since the robot's start) and ``frame`` (frame index).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.sensors import Frame
from roman_sim.core.trajectory import Trajectory

if TYPE_CHECKING:
    from rerun import RecordingStream

    from roman_sim.interop.objects import ObjectRow
    from roman_sim.mapping.mapper import SegmentMap
    from roman_sim.mapping.types import Submap
    from roman_sim.world.truth import Terrain

F64 = NDArray[np.float64]

#: Colours of the trajectory variants (anything else: the method's colour).
TRAJECTORY_COLOURS = {"truth": (40, 40, 40), "odometry": (230, 120, 20), "oracle": (150, 150, 150)}
METHOD_COLOUR = (30, 110, 230)
CLOSURE_COLOURS = {"correct": (30, 180, 60), "wrong": (220, 30, 30), "rejected": (240, 200, 40)}


def _family_colour(k: int) -> tuple[int, int, int]:
    import matplotlib

    r, g, b, _ = matplotlib.colormaps["tab20"](k % 20)
    return int(255 * r), int(255 * g), int(255 * b)


def log_objects(rec: RecordingStream, rows: list[ObjectRow]) -> None:
    """Objects as oriented boxes, coloured and labelled by family.

    Args:
        rows: object records as ``roman_sim.interop.objects`` writes them (``object_rows`` of a
            world's truth, or ``read_object_table`` of an exported sequence).
    """
    import rerun as rr

    if not rows:
        return
    families = sorted({r.family for r in rows})
    rec.log(
        "world/objects", rr.AnnotationContext([(k, f, _family_colour(k)) for k, f in enumerate(families)]), static=True
    )
    rec.log(
        "world/objects",
        rr.Boxes3D(
            centers=[r.box.center for r in rows],
            half_sizes=np.asarray([r.box.extents for r in rows]) / 2,
            quaternions=[r.box.quaternion_xyzw for r in rows],
            class_ids=[families.index(r.family) for r in rows],
            labels=[f"{r.family} {r.id}" for r in rows],
        ),
        static=True,
    )


def log_terrain(rec: RecordingStream, terrain: Terrain, max_side: int = 96) -> None:
    """The heightfield as a triangle mesh (subsampled to at most ``max_side`` per side)."""
    import rerun as rr

    rows, cols = terrain.shape
    nr, nc = min(rows, max_side), min(cols, max_side)
    x = np.linspace(-terrain.size_x / 2, terrain.size_x / 2, nc)
    y = np.linspace(-terrain.size_y / 2, terrain.size_y / 2, nr)
    X, Y = np.meshgrid(x, y)
    Z = terrain.height_at(X.ravel(), Y.ravel())
    verts = np.column_stack([X.ravel(), Y.ravel(), Z])
    i = np.arange(nr - 1)[:, None] * nc + np.arange(nc - 1)[None, :]
    tris = np.concatenate(
        [np.stack([i, i + 1, i + nc], -1).reshape(-1, 3), np.stack([i + 1, i + nc + 1, i + nc], -1).reshape(-1, 3)]
    )
    rec.log(
        "world/terrain",
        rr.Mesh3D(vertex_positions=verts, triangle_indices=tris, albedo_factor=(120, 140, 100, 255)),
        static=True,
    )


def log_trajectories(rec: RecordingStream, trajectories: dict[str, dict[str, Trajectory]]) -> None:
    """Each robot's trajectories as line strips (already in the world frame)."""
    import rerun as rr

    for robot, variants in trajectories.items():
        for variant, traj in variants.items():
            colour = TRAJECTORY_COLOURS.get(variant, METHOD_COLOUR)
            rec.log(
                f"world/trajectories/{robot}/{variant}",
                rr.LineStrips3D([traj.positions], colors=[colour], radii=[0.05], labels=[f"{robot} {variant}"]),
                static=True,
            )


def log_transform(rec: RecordingStream, path: str, T: F64, static: bool = False) -> None:
    """A 4x4 pose as a rerun transform of ``path`` relative to its parent."""
    import rerun as rr

    rec.log(path, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]), static=static)


def log_segment_map(rec: RecordingStream, robot: str, smap: SegmentMap, T_world_odom: F64) -> None:
    """A robot's segments (odometry frame) under its placed odometry frame."""
    import rerun as rr

    base = f"world/maps/{robot}"
    log_transform(rec, base, T_world_odom, static=True)
    segs = smap.segments
    if not segs:
        return
    pts = np.concatenate([s.points for s in segs])
    ids = np.concatenate([np.full(len(s.points), s.id) for s in segs])
    rec.log(f"{base}/points", rr.Points3D(pts, class_ids=ids % 65536, radii=[0.03]), static=True)
    rec.log(
        f"{base}/centroids",
        rr.Points3D(np.stack([s.center for s in segs]), radii=[0.12], labels=[f"{robot}:{s.id}" for s in segs]),
        static=True,
    )


def log_submaps(rec: RecordingStream, robot: str, submaps: Iterable[Submap], T_world_odom: F64) -> None:
    """Each submap's frame (true pose, else the placed odometry) and its segment centres."""
    import rerun as rr

    for s in submaps:
        T = s.truth.T_world_submap if s.truth is not None else T_world_odom @ s.T_odom_submap
        path = f"world/submaps/{robot}/{s.index}"
        log_transform(rec, path, np.asarray(T, dtype=np.float64), static=True)
        rec.log(
            f"{path}/segments",
            rr.Points3D(np.asarray(s.centers).reshape(-1, 3), radii=[0.1], colors=[METHOD_COLOUR]),
            static=True,
        )


def log_closures(rec: RecordingStream, segments: dict[str, list[tuple[F64, F64]]]) -> None:
    """Loop closures as lines between submap centres, one entity per verdict."""
    import rerun as rr

    for verdict, lines in segments.items():
        if lines:
            rec.log(
                f"world/loop_closures/{verdict}",
                rr.LineStrips3D([np.stack(ab) for ab in lines], colors=[CLOSURE_COLOURS[verdict]], radii=[0.08]),
                static=True,
            )


def log_camera(rec: RecordingStream, robot: str, frame: Frame, T_world_cam: F64, first: bool) -> None:
    """One frame on the timeline: camera pose, and RGB, depth and instance mask over it."""
    import rerun as rr

    base = f"world/robots/{robot}/camera"
    rec.set_time("time", duration=float(frame.t))
    rec.set_time("frame", sequence=int(frame.index))
    if first:
        k = frame.intrinsics
        rec.log(
            base,
            rr.Pinhole(
                image_from_camera=k.K,
                resolution=[k.width, k.height],
                camera_xyz=rr.ViewCoordinates.RDF,
                image_plane_distance=1.0,
            ),
            static=True,
        )
    log_transform(rec, base, T_world_cam)
    if frame.rgb is not None:
        rec.log(f"{base}/rgb", rr.Image(np.asarray(frame.rgb, dtype=np.uint8)))
    rec.log(f"{base}/depth", rr.DepthImage(np.asarray(frame.depth, dtype=np.float32), meter=1.0))
    if frame.truth is not None and frame.truth.object_ids is not None:
        mask = (np.asarray(frame.truth.object_ids, dtype=np.int64) + 1).astype(np.uint16)
        rec.log(f"{base}/mask", rr.SegmentationImage(mask, opacity=0.5))
