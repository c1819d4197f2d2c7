"""Free-space queries: clearance of points from object footprints, road distances."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from roman_sim.core.errors import WorldError
from roman_sim.world.roads import distance_to_roads
from roman_sim.world.truth import WorldTruth


def _as_xy(xy: ArrayLike) -> NDArray[np.float64]:
    arr = np.asarray(xy, dtype=np.float64)
    if arr.ndim == 1 and arr.shape == (2,):
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != 2 or not np.all(np.isfinite(arr)):
        raise WorldError(f"xy must be finite points of shape (N, 2), got shape {arr.shape}")
    return arr


def footprints(truth: WorldTruth) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Object footprint discs: centres (N, 2) (object origins) and radii (N,)."""
    if not truth.objects:
        return np.zeros((0, 2)), np.zeros(0)
    xy = np.stack([o.T_world_obj[:2, 3] for o in truth.objects])
    return xy, np.array([o.radius for o in truth.objects])


def clearance(truth: WorldTruth, xy: ArrayLike) -> NDArray[np.float64]:
    """(N,) distance from each point of ``xy`` (N, 2) to the nearest footprint disc edge.

    Negative inside a footprint; ``inf`` in a world without objects. Exact: every disc
    whose centre lies within (nearest centre distance + max radius) is checked.
    """
    pts = _as_xy(xy)
    centres, radii = footprints(truth)
    if len(centres) == 0:
        return np.full(len(pts), np.inf)
    tree = cKDTree(centres)
    d0, _ = tree.query(pts)
    out = np.empty(len(pts))
    for i, (p, reach) in enumerate(zip(pts, d0 + radii.max())):
        idx = tree.query_ball_point(p, reach)
        out[i] = np.min(np.hypot(*(centres[idx] - p).T) - radii[idx])
    return out


def is_free(truth: WorldTruth, xy: ArrayLike, margin: float = 0.0) -> NDArray[np.bool_]:
    """(N,) whether each point keeps ``margin`` metres from every footprint and lies in the extent."""
    pts = _as_xy(xy)
    t = truth.terrain
    inside = (np.abs(pts[:, 0]) <= t.size_x / 2 - margin) & (np.abs(pts[:, 1]) <= t.size_y / 2 - margin)
    return inside & (clearance(truth, pts) >= margin)


def road_distance(truth: WorldTruth, xy: ArrayLike) -> NDArray[np.float64]:
    """(N,) distance from each point to the nearest road centre line (``inf`` without roads)."""
    return distance_to_roads(_as_xy(xy), truth.roads)
