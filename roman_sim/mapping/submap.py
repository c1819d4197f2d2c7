"""Submaps: segments near a centre pose, in its gravity-aligned frame.

Centres are placed along the odometry trajectory whenever the robot has moved more than
``submap_center_dist`` from the previous centre or ``submap_center_time`` has passed. A
submap holds the ``submap_max_size`` segments closest to its centre among those within
``submap_radius`` that were seen within +-``time_window_s`` of the centre time. Only the
odometry pose is used to build it; the true pose goes into ``SubmapTruth``.
"""

from __future__ import annotations

import logging
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.core.geometry import gravity_aligned, inv_T, transform_points
from roman_sim.mapping.mapper import SegmentMap
from roman_sim.mapping.segment import Segment
from roman_sim.mapping.types import Submap, SubmapTruth

log = logging.getLogger(__name__)


class SubmapConfig(StrictModel):
    """Submap placement and membership (reference names)."""

    submap_center_dist: float = Field(10.0, gt=0)
    submap_center_time: float = Field(50.0, gt=0)
    submap_radius: float = Field(15.0, gt=0)
    submap_max_size: int = Field(40, ge=1, le=10000)
    time_window_s: float = Field(50.0, ge=0)
    keep_points: bool = False
    descriptor_dtype: Literal["float32", "float16"] = "float32"


def center_indices(times: NDArray[np.float64], T_odom_body: NDArray[np.float64], cfg: SubmapConfig) -> list[int]:
    """Trajectory indices of the submap centres (the first pose is always one)."""
    if len(times) == 0:
        return []
    out = [0]
    for i in range(1, len(times)):
        c = out[-1]
        moved = np.linalg.norm(T_odom_body[i, :3, 3] - T_odom_body[c, :3, 3])
        if moved > cfg.submap_center_dist or times[i] - times[c] > cfg.submap_center_time:
            out.append(i)
    return out


def members(segments: list[Segment], center: NDArray[np.float64], t: float, cfg: SubmapConfig) -> list[Segment]:
    """The segments of a submap at ``center`` (odometry frame) and time ``t``, by distance."""
    cands = []
    for s in segments:
        if s.last_seen < t - cfg.time_window_s or s.first_seen > t + cfg.time_window_s:
            continue
        dist = float(np.linalg.norm(s.center - center))
        if dist <= cfg.submap_radius:
            cands.append((dist, s.id, s))
    cands.sort(key=lambda x: (x[0], x[1]))
    return [s for _, _, s in cands[: cfg.submap_max_size]]


def make_submap(
    robot: str,
    index: int,
    t: float,
    T_odom_body: NDArray[np.float64],
    T_world_body: NDArray[np.float64] | None,
    segs: list[Segment],
    cfg: SubmapConfig,
) -> Submap:
    """One submap from its member segments and the centre's odometry and true poses (truth None without)."""
    T_odom_sub = gravity_aligned(T_odom_body)
    T_sub_odom = inv_T(T_odom_sub)
    n = len(segs)
    dim = next((len(s.descriptor) for s in segs if s.descriptor is not None), 0)
    desc = np.zeros((n, dim), dtype=cfg.descriptor_dtype)
    for k, s in enumerate(segs):
        if s.descriptor is not None:
            desc[k] = s.descriptor
    centers = transform_points(T_sub_odom, np.array([s.center for s in segs]).reshape(-1, 3))
    return Submap(
        robot=robot,
        index=index,
        t=float(t),
        T_odom_submap=T_odom_sub,
        segment_ids=np.array([s.id for s in segs], dtype=np.int64),
        centers=centers,
        volumes=np.array([s.volume for s in segs], dtype=np.float64),
        shape=np.array([s.shape for s in segs], dtype=np.float64).reshape(n, 3),
        descriptors=desc,
        extents=np.array([s.extents for s in segs], dtype=np.float64).reshape(n, 3),
        points=[transform_points(T_sub_odom, s.points) for s in segs] if cfg.keep_points else None,
        truth=None
        if T_world_body is None
        else SubmapTruth(
            T_world_submap=gravity_aligned(T_world_body),
            object_ids=np.array([s.majority_id for s in segs], dtype=np.int64),
            purity=np.array([s.purity for s in segs], dtype=np.float64),
        ),
    )


def build_submaps(segment_map: SegmentMap, cfg: SubmapConfig | None = None) -> list[Submap]:
    """Submaps along the robot's trajectory (empty list for an empty trajectory)."""
    cfg = cfg or SubmapConfig()
    sm = segment_map
    out = []
    for k, i in enumerate(center_indices(sm.times, sm.T_odom_body, cfg)):
        segs = members(sm.segments, sm.T_odom_body[i, :3, 3], float(sm.times[i]), cfg)
        T_wb = None if sm.T_world_body is None else sm.T_world_body[i]
        out.append(make_submap(sm.robot, k, float(sm.times[i]), sm.T_odom_body[i], T_wb, segs, cfg))
    log.info("robot %s: %d submaps", sm.robot, len(out))
    return out
