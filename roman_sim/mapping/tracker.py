"""Segment tracking: voxel-IoU association, lifecycle, merging and removal filters.

Implements ROMAN's tracking: observations (already in the odometry frame) are
associated to nursery/active segments by 3D voxel IoU (0.2 m) with Hungarian assignment
(IoU < ``min_iou`` not allowed); unmatched observations start nursery segments. Nursery
segments become active after ``min_sightings``; unseen segments go inactive (largest
cluster kept) and later finished. Overlapping segments merge, keeping the older id.

Deviation from the reference: besides 3D IoU > ``merge_iou``, two segments also merge
when more than ``merge_contained`` of the smaller one's points lie within
``merge_contained_dist_m`` of the larger one's points.
Partial views of an object leaving the image have a low IoU with the full segment and
would otherwise stay as duplicates; set ``merge_contained`` above 1 for the reference
behaviour.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, SerializerFunctionWrapHandler, model_serializer, model_validator
from scipy.optimize import linear_sum_assignment

from roman_sim.core.config import StrictModel
from roman_sim.mapping.segment import Segment, Status, contained_fraction
from roman_sim.mapping.voxels import iou, iou_matrix, voxel_set

log = logging.getLogger(__name__)


class MappingConfig(StrictModel):
    """Front-end parameters (names follow the reference implementation).

    Attributes:
        max_depth_m, min_valid_fraction: depth truncation and the in-range pixel share a
            mask needs to be kept.
        voxel: point voxel size (m); iou_voxel: voxel size (m) of the association IoU.
        min_iou: smallest IoU an association may have; merge_iou: IoU above which two
            segments merge; merge_contained, merge_contained_dist_m: containment merge.
        min_sightings: sightings that turn a nursery segment active.
        nursery_time_s, active_time_s: unseen time after which a nursery segment is
            deleted / an active one goes inactive.
        inactive_time_s, inactive_dist_m: unseen time or robot distance that finishes an
            inactive segment.
        cluster_eps_m: largest-cluster cleanup scale; min_max_extent_m: speck filter.
        obs_plane_extents_m, seg_plane_extents_m: plane filters (descending extents).
        min_points: fewest points an observation or segment may have.
        whole_surface: a counterfactual of the simulator, not a front-end setting: each
            observation's points come from its objects' whole surfaces instead of the side the
            depth image shows (the pipeline supplies them from the world; ``Mapper``'s ``reshape``).
        complete: the same split by reason (one-sided visibility, occlusion, range truncation,
            the image's edges): the observation keeps its points and gains its objects' surface
            missed only for the named reasons (``roman_sim.frontend.surface_completion``).
    """

    max_depth_m: float = Field(7.5, gt=0, le=100)
    min_valid_fraction: float = Field(0.25, ge=0, le=1)
    voxel: float = Field(0.05, gt=0, le=1)
    iou_voxel: float = Field(0.2, gt=0, le=2)
    min_iou: float = Field(0.25, ge=0, le=1)
    merge_iou: float = Field(0.25, ge=0, le=1)
    merge_contained: float = Field(0.6, ge=0, le=1.01)
    merge_contained_dist_m: float = Field(0.1, ge=0, le=2)
    min_sightings: int = Field(2, ge=1, le=100)
    nursery_time_s: float = Field(0.4, ge=0)
    active_time_s: float = Field(0.4, ge=0)
    inactive_time_s: float = Field(15.0, ge=0)
    inactive_dist_m: float = Field(10.0, ge=0)
    cluster_eps_m: float = Field(0.25, gt=0)
    min_max_extent_m: float = Field(0.25, ge=0)
    obs_plane_extents_m: tuple[float, float, float] = (3.0, 1.0, 0.2)
    seg_plane_extents_m: tuple[float, float, float] = (3.0, 3.0, 0.5)
    min_points: int = Field(4, ge=1)
    whole_surface: bool = Field(
        False, description="counterfactual: observations take their objects' whole surfaces (simulated frames only)"
    )
    complete: list[Literal["back_side", "occluded", "beyond_range", "out_of_view"]] = Field(
        default_factory=list,
        description="counterfactual: the reasons a camera misses part of an object whose misses are filled in from "
        "the object's surface (simulated frames only; roman_sim.frontend.surface_completion)",
    )

    @model_serializer(mode="wrap")
    def _without_empty_complete(self, handler: SerializerFunctionWrapHandler) -> dict[str, object]:
        """``complete`` is left out of the dump when empty, so a scenario without it keeps its hash."""
        data: dict[str, object] = handler(self)
        if data.get("complete") == []:
            del data["complete"]
        return data

    @model_validator(mode="after")
    def _one_counterfactual(self) -> "MappingConfig":
        if self.whole_surface and self.complete:
            raise ValueError("complete: whole_surface already fills in every reason; set one of the two")
        if len(set(self.complete)) != len(self.complete):
            raise ValueError(f"complete: each reason once, got {self.complete}")
        return self


@dataclass
class Observation:
    """One segmented mask in the odometry frame.

    Attributes:
        points: (N, 3) voxel-downsampled points in the odometry frame.
        t: time (s).
        descriptor: unit embedding or None.
        truth: evaluation only: point count per true object id.
    """

    points: NDArray[np.float64]
    t: float
    descriptor: NDArray[np.float32] | None
    truth: Counter


def is_plane_like(ext_desc: NDArray[np.float64], lim: tuple[float, float, float]) -> bool:
    """Plane filter on descending extents: e0 > lim0 and e1 > lim1 and e2 < lim2.

    Observations use (3.0, 1.0, 0.2), segments (3.0, 3.0, 0.5) (the reference's ascending
    form e2 > 3, e1 > 3, e0 < 0.5).
    """
    return bool(ext_desc[0] > lim[0] and ext_desc[1] > lim[1] and ext_desc[2] < lim[2])


class Tracker:
    """Keeps nursery/active/inactive segments and the finished list."""

    def __init__(self, cfg: MappingConfig) -> None:
        self.cfg = cfg
        self.live: list[Segment] = []
        self.finished: list[Segment] = []
        self._next_id = 0

    def update(self, obs: list[Observation], t: float, position: NDArray[np.float64]) -> None:
        """Associate ``obs`` at time ``t`` and advance the lifecycle.

        Args:
            obs: observations of this frame (odometry frame).
            t: frame time (s).
            position: (3,) current odometry position of the robot.
        """
        cands = [s for s in self.live if s.status in (Status.NURSERY, Status.ACTIVE)]
        seen = self._associate(obs, cands, t)
        self._merge(seen)
        self._lifecycle(t, position)

    def _associate(self, obs: list[Observation], cands: list[Segment], t: float) -> list[Segment]:
        v = self.cfg.iou_voxel
        M = iou_matrix([voxel_set(o.points, v) for o in obs], [s.voxels(v) for s in cands])
        matched: dict[int, Segment] = {}
        if M.size:
            cost = np.where(M >= self.cfg.min_iou, -M, 1.0)
            for i, j in zip(*linear_sum_assignment(cost)):
                if M[i, j] >= self.cfg.min_iou:
                    matched[int(i)] = cands[int(j)]
        seen: list[Segment] = []
        for i, o in enumerate(obs):
            seg = matched.get(i)
            if seg is None:
                seg = Segment(self._next_id, np.zeros((0, 3)), t, t, 0)
                self._next_id += 1
                self.live.append(seg)
            seg.add_observation(o.points, t, o.descriptor, o.truth, self.cfg.voxel)
            if seg.status is Status.NURSERY and seg.num_sightings >= self.cfg.min_sightings:
                seg.status = Status.ACTIVE
            seen.append(seg)
        return seen

    def _merge(self, seen: list[Segment]) -> None:
        """Merge each segment seen this frame with any live segment it overlaps."""
        for seg in seen:
            if seg not in self.live:
                continue
            for other in self._near(seg):
                if other is seg or other not in self.live or seg not in self.live:
                    continue
                if self._should_merge(seg, other):
                    keep, drop = (seg, other) if seg.id < other.id else (other, seg)
                    keep.absorb(drop, self.cfg.voxel)
                    keep.status = _merged_status(keep, drop, self.cfg.min_sightings)
                    self.live.remove(drop)
                    log.debug("merged segment %d into %d", drop.id, keep.id)
                    seg = keep

    def _near(self, seg: Segment) -> list[Segment]:
        """Live segments whose bounds come close enough to ``seg``'s to overlap at all."""
        if not self.live:
            return []
        m = max(self.cfg.iou_voxel, self.cfg.merge_contained_dist_m)
        lo = np.array([s.bounds[0] for s in self.live])
        hi = np.array([s.bounds[1] for s in self.live])
        slo, shi = seg.bounds
        ok = np.all(lo - m <= shi, axis=1) & np.all(slo - m <= hi, axis=1)
        return [s for s, k in zip(self.live, ok) if k and s is not seg]

    def _should_merge(self, a: Segment, b: Segment) -> bool:
        c = self.cfg
        if iou(a.voxels(c.iou_voxel), b.voxels(c.iou_voxel)) > c.merge_iou:
            return True
        if c.merge_contained > 1:
            return False
        small, big = (a, b) if len(a.points) <= len(b.points) else (b, a)
        return contained_fraction(small.points, big, c.merge_contained_dist_m) > c.merge_contained

    def _lifecycle(self, t: float, position: NDArray[np.float64]) -> None:
        c = self.cfg
        for seg in list(self.live):
            unseen = t - seg.last_seen
            if seg.status is Status.NURSERY and unseen > c.nursery_time_s:
                self.live.remove(seg)
            elif seg.status is Status.ACTIVE and unseen > c.active_time_s:
                self._deactivate(seg)
            elif seg.status is Status.INACTIVE:
                far = np.linalg.norm(seg.center - position) > c.inactive_dist_m
                if unseen > c.inactive_time_s or far:
                    self._finish(seg)

    def _deactivate(self, seg: Segment) -> None:
        seg.keep_largest_cluster(self.cfg.cluster_eps_m)
        if self.keep(seg):
            seg.status = Status.INACTIVE
        else:
            self.live.remove(seg)

    def _finish(self, seg: Segment) -> None:
        self.live.remove(seg)
        if self.keep(seg):
            seg.status = Status.FINISHED
            self.finished.append(seg)

    def keep(self, seg: Segment) -> bool:
        """Removal filters: too few points, specks (max extent small), plane-like."""
        if len(seg.points) < self.cfg.min_points:
            return False
        ext = seg.extents
        if ext[0] < self.cfg.min_max_extent_m:
            return False
        return not is_plane_like(ext, self.cfg.seg_plane_extents_m)

    def flush(self) -> list[Segment]:
        """Finish every live segment (nursery ones are dropped); return all finished."""
        for seg in list(self.live):
            if seg.status is Status.NURSERY:
                self.live.remove(seg)
            else:
                if seg.status is Status.ACTIVE:
                    seg.keep_largest_cluster(self.cfg.cluster_eps_m)
                self._finish(seg)
        self.finished.sort(key=lambda s: s.id)
        return self.finished


def _merged_status(keep: Segment, drop: Segment, min_sightings: int) -> Status:
    if Status.ACTIVE in (keep.status, drop.status) or keep.num_sightings >= min_sightings:
        return Status.ACTIVE
    return keep.status
