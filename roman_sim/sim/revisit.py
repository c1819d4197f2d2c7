"""Revisits that are not replays: another start on the same line, and a sideways offset within the road.

A robot that follows a road another robot drives (or that robot's line, reversed or in
pieces) starts where ``PathConfig.start_fraction`` says and keeps ``lateral_offset_m`` to
the left of its own direction of travel. The offset line is the base line moved along its
normals; where a bend is tighter than the offset (inside a corner) the moved points that
would run backwards are dropped, so the line stays drivable. Written by hand because the
project has no polygon-offset library (shapely's ``offset_curve`` does this for polygons);
the offsets here are small against the roads' bend radii.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import SimError

F64 = NDArray[np.float64]

#: A line whose ends are this close (m) is closed: starting elsewhere drives it whole.
CLOSED_TOL_M = 0.5


def offset_range(
    bounds: tuple[float, float], road_width_m: float | None, clearance_m: float, name: str
) -> tuple[float, float]:
    """The offset range, checked against the road: ``|offset| <= road_width_m / 2 - clearance_m``.

    Raises: SimError naming ``path.lateral_offset_m`` and the allowed range when it leaves the road.
    """
    lo, hi = float(bounds[0]), float(bounds[1])
    if road_width_m is None:
        return lo, hi
    half = max(road_width_m / 2.0 - clearance_m, 0.0)
    if lo < -half - 1e-9 or hi > half + 1e-9:
        raise SimError(
            f"robot {name!r}: path.lateral_offset_m {[lo, hi]} leaves the road: allowed within "
            f"[{-half:g}, {half:g}] m (half the road width {road_width_m:g} m less the clearance {clearance_m:g} m)"
        )
    return lo, hi


def offset_polyline(xy: F64, heading: F64, offset_m: float) -> F64:
    """``xy`` (K, 2) moved ``offset_m`` to the left of ``heading`` (K,), backward-running points dropped."""
    normal = np.column_stack([-np.sin(heading), np.cos(heading)])
    tangent = np.column_stack([np.cos(heading), np.sin(heading)])
    moved = xy + offset_m * normal
    keep = [0]
    for k in range(1, len(moved)):
        if float(np.dot(moved[k] - moved[keep[-1]], tangent[k])) > 0.0:
            keep.append(k)
    if keep[-1] != len(moved) - 1 and np.linalg.norm(xy[0] - xy[-1]) <= CLOSED_TOL_M:
        keep.append(len(moved) - 1)  # a closed line stays closed
    return moved[keep]


def start_at(xy: F64, fraction: float) -> F64:
    """The line ``xy`` (K, 2) started ``fraction`` of its length along (closed: whole, open: to its end)."""
    steps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    s0 = float(fraction) * s[-1]
    i = int(np.clip(np.searchsorted(s, s0, side="right"), 1, len(xy) - 1))
    a = (s0 - s[i - 1]) / max(s[i] - s[i - 1], 1e-12)
    p = xy[i - 1] + a * (xy[i] - xy[i - 1])
    if np.linalg.norm(xy[0] - xy[-1]) > CLOSED_TOL_M:
        return np.vstack([p, xy[i:]])
    return np.vstack([p, xy[i:-1], xy[:i], p])
