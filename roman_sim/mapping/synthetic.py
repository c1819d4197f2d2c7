"""Synthetic RGB-D frames without a renderer: spheres over a ground plane, ray-cast in numpy.

Used by the mapping tests and the mapping benchmark to get exact, cheap frames with known
object ids (sphere k has id k).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.geometry import R_FLU_RDF, make_T, rot_z
from roman_sim.core.sensors import Frame, FrameTruth, Intrinsics

Sphere = tuple[NDArray[np.float64], float]

#: Camera 0.5 m above the body origin, looking forward (FLU body, RDF camera).
T_BODY_CAM = make_T(R_FLU_RDF, [0.0, 0.0, 0.5])


def intrinsics(width: int = 160, height: int = 120, hfov_deg: float = 90.0) -> Intrinsics:
    """Square-pixel intrinsics with a centred principal point."""
    f = (width / 2.0) / np.tan(np.radians(hfov_deg) / 2.0)
    return Intrinsics(width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0)


def render(
    spheres: list[Sphere], T_world_cam: NDArray[np.float64], intr: Intrinsics, ground: bool = True
) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
    """(depth, ids) images: depth along the optical axis (0 = no hit), ids -1 for ground/sky."""
    v, u = np.mgrid[0 : intr.height, 0 : intr.width]
    d_cam = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones(u.shape)], -1)
    d_w = d_cam @ T_world_cam[:3, :3].T  # z-component 1 in the camera: ray parameter = depth
    o = T_world_cam[:3, 3]
    best = np.full(u.shape, np.inf)
    ids = np.full(u.shape, -1, dtype=np.int32)
    if ground:
        dz = d_w[..., 2]
        tg = np.full(u.shape, np.inf)
        down = dz < -1e-9
        tg[down] = -o[2] / dz[down]
        best = tg
    a = np.sum(d_w * d_w, -1)
    for k, (c, r) in enumerate(spheres):
        oc = o - np.asarray(c, dtype=np.float64)
        b = 2.0 * (d_w @ oc)
        disc = b * b - 4.0 * a * (oc @ oc - r * r)
        hit = disc >= 0
        t = np.full(u.shape, np.inf)
        t[hit] = (-b[hit] - np.sqrt(disc[hit])) / (2.0 * a[hit])
        closer = (t > 0) & (t < best)
        best[closer] = t[closer]
        ids[closer] = k
    depth = np.where(np.isfinite(best), best, 0.0).astype(np.float32)
    return depth, ids


def frame_at(
    spheres: list[Sphere],
    x: float,
    y: float,
    yaw: float,
    t: float,
    index: int,
    T_odom_world: NDArray[np.float64] | None = None,
    robot: str = "a",
    intr: Intrinsics | None = None,
) -> Frame:
    """A frame with the body at (x, y, 0) heading ``yaw``; odometry = ``T_odom_world`` @ truth."""
    intr = intr or intrinsics()
    T_wb = make_T(rot_z(yaw), [x, y, 0.0])
    depth, ids = render(spheres, T_wb @ T_BODY_CAM, intr)
    T_ob = (np.eye(4) if T_odom_world is None else T_odom_world) @ T_wb
    return Frame(
        robot=robot,
        index=index,
        t=t,
        rgb=None,
        depth=depth,
        T_odom_body=T_ob,
        T_body_cam=T_BODY_CAM,
        intrinsics=intr,
        truth=FrameTruth(ids, T_wb),
    )


def drive(
    spheres: list[Sphere],
    n: int = 12,
    dt: float = 1 / 6,
    speed: float = 1.0,
    T_odom_world: NDArray[np.float64] | None = None,
    intr: Intrinsics | None = None,
) -> list[Frame]:
    """Frames of a robot driving along +x from the origin."""
    return [frame_at(spheres, speed * dt * i, 0.0, 0.0, dt * i, i, T_odom_world, intr=intr) for i in range(n)]


def sphere_field(
    n: int,
    seed: int,
    x_range: tuple[float, float] = (2.5, 8.0),
    half_width: float = 3.5,
    radius_range: tuple[float, float] = (0.15, 0.45),
    max_tries: int = 100_000,
) -> list[Sphere]:
    """Up to ``n`` non-overlapping spheres resting on the ground ahead of the origin."""
    rng = np.random.default_rng(seed)
    centres = np.zeros((0, 3))
    radii = np.zeros(0)
    for _ in range(max_tries):
        if len(radii) == n:
            break
        r = float(rng.uniform(*radius_range))
        c = np.array([rng.uniform(*x_range), rng.uniform(-half_width, half_width), r])
        if np.all(np.linalg.norm(centres - c, axis=1) > radii + r + 0.1):
            centres, radii = np.vstack([centres, c]), np.append(radii, r)
    return [(c, float(r)) for c, r in zip(centres, radii)]
