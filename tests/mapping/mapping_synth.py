"""Synthetic frames for mapping tests: spheres and a ground plane ray-cast in numpy."""

from __future__ import annotations

import numpy as np

from roman_sim.geometry import R_FLU_RDF, make_T, rot_z
from roman_sim.sim.frame import Frame, Intrinsics

INTR = Intrinsics(width=160, height=120, fx=80.0, fy=80.0, cx=79.5, cy=59.5)
T_BODY_CAM = make_T(R_FLU_RDF, [0.0, 0.0, 0.5])


def render(spheres: list[tuple[np.ndarray, float]], T_world_body: np.ndarray,
           intr: Intrinsics = INTR, ground: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(depth float32, ids int32) of spheres (centre, radius) with ids 0..n-1."""
    T = T_world_body @ T_BODY_CAM
    v, u = np.mgrid[0:intr.height, 0:intr.width]
    d_cam = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones_like(u, float)], -1)
    d_w = d_cam @ T[:3, :3].T
    o = T[:3, 3]
    best = np.full(u.shape, np.inf)
    ids = np.full(u.shape, -1, dtype=np.int32)
    if ground:
        with np.errstate(divide="ignore", invalid="ignore"):
            tg = np.where(d_w[..., 2] < -1e-9, -o[2] / d_w[..., 2], np.inf)
        best = np.minimum(best, tg)
    for k, (c, r) in enumerate(spheres):
        oc = o - np.asarray(c)
        a = np.sum(d_w * d_w, -1)
        b = 2 * d_w @ oc
        cc = oc @ oc - r * r
        disc = b * b - 4 * a * cc
        t = np.where(disc >= 0, (-b - np.sqrt(np.maximum(disc, 0))) / (2 * a), np.inf)
        t = np.where(t > 0, t, np.inf)
        hit = t < best
        best = np.where(hit, t, best)
        ids[hit] = k
    depth = np.where(np.isfinite(best), best, 0).astype(np.float32)
    return depth, ids


def frame_at(spheres, x: float, y: float, yaw: float, t: float, index: int,
             T_odom_world: np.ndarray | None = None, robot: str = "a") -> Frame:
    """A frame with the body at (x, y, 0) heading ``yaw``."""
    T_wb = make_T(rot_z(yaw), [x, y, 0.0])
    depth, ids = render(spheres, T_wb)
    T_ob = (np.eye(4) if T_odom_world is None else T_odom_world) @ T_wb
    return Frame(robot=robot, index=index, t=t, rgb=None, depth=depth, object_ids=ids,
                 T_world_body=T_wb, T_odom_body=T_ob, T_body_cam=T_BODY_CAM, intrinsics=INTR)


SPHERES = [(np.array([5.0, 1.0, 0.6]), 0.6), (np.array([6.0, -1.5, 0.8]), 0.8), (np.array([4.0, -0.2, 0.4]), 0.4)]


def drive(spheres=SPHERES, n: int = 12, dt: float = 1 / 6, speed: float = 1.0, T_odom_world=None):
    """Frames of a robot driving along +x from the origin."""
    return [frame_at(spheres, speed * dt * i, 0.0, 0.0, dt * i, i, T_odom_world) for i in range(n)]
