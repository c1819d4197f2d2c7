"""Road networks: polylines kept free of objects so robots have somewhere to drive."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.registry import Registry
from roman_sim.world.spec import RoadSpec

Polyline = NDArray[np.float64]  # (K, 2)
RoadBuilder = Callable[[RoadSpec, tuple[float, float]], list[Polyline]]
ROAD_STYLES: Registry[RoadBuilder] = Registry("road style")

_STEP_M = 2.0  # polyline vertex spacing


def _segment(a: tuple[float, float], b: tuple[float, float]) -> Polyline:
    n = max(2, int(np.ceil(np.hypot(b[0] - a[0], b[1] - a[1]) / _STEP_M)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) * np.asarray(a, float) + t * np.asarray(b, float)


def _loop(spec: RoadSpec, extent: tuple[float, float]) -> list[Polyline]:
    """A closed rounded-rectangle loop inset ``margin_frac`` from the edges."""
    hx = extent[0] * (0.5 - spec.margin_frac)
    hy = extent[1] * (0.5 - spec.margin_frac)
    rc = 0.3 * min(hx, hy)
    pts: list[NDArray[np.float64]] = []
    corners = [
        (hx - rc, hy - rc, 0.0),
        (-hx + rc, hy - rc, 0.5 * np.pi),
        (-hx + rc, -hy + rc, np.pi),
        (hx - rc, -hy + rc, 1.5 * np.pi),
    ]
    n_arc = max(4, int(np.ceil(0.5 * np.pi * rc / _STEP_M)))
    for cx, cy, a0 in corners:
        a = a0 + np.linspace(0.0, 0.5 * np.pi, n_arc)
        arc = np.stack([cx + rc * np.cos(a), cy + rc * np.sin(a)], axis=1)
        if pts:
            pts.append(_segment(tuple(pts[-1][-1]), tuple(arc[0]))[1:-1])
        pts.append(arc)
    loop = np.concatenate(pts)
    closing = _segment(tuple(loop[-1]), tuple(loop[0]))[1:]
    return [np.concatenate([loop, closing])]


def _cross(spec: RoadSpec, extent: tuple[float, float]) -> list[Polyline]:
    """Two straight roads crossing the world through its centre."""
    hx, hy = extent[0] * 0.49, extent[1] * 0.49
    return [_segment((-hx, 0.0), (hx, 0.0)), _segment((0.0, -hy), (0.0, hy))]


def _loop_cross(spec: RoadSpec, extent: tuple[float, float]) -> list[Polyline]:
    return _loop(spec, extent) + _cross(spec, extent)


def _grid(spec: RoadSpec, extent: tuple[float, float]) -> list[Polyline]:
    """Straight roads every ``spacing_m`` in x and y (a street grid)."""
    hx, hy = extent[0] * 0.49, extent[1] * 0.49
    xs = np.arange(-hx + spec.spacing_m / 2, hx, spec.spacing_m)
    ys = np.arange(-hy + spec.spacing_m / 2, hy, spec.spacing_m)
    return [_segment((x, -hy), (x, hy)) for x in xs] + [_segment((-hx, y), (hx, y)) for y in ys]


ROAD_STYLES.register("loop", _loop)
ROAD_STYLES.register("cross", _cross)
ROAD_STYLES.register("loop_cross", _loop_cross)
ROAD_STYLES.register("grid", _grid)


def make_roads(spec: RoadSpec, extent: tuple[float, float]) -> list[Polyline]:
    """The road polylines of a world (each (K, 2), metres)."""
    return ROAD_STYLES.get(spec.style.value)(spec, extent)


def distance_to_roads(xy: NDArray[np.float64], roads: list[Polyline]) -> NDArray[np.float64]:
    """(N,) distance from each point of ``xy`` (N, 2) to the nearest road segment (inf if none)."""
    xy = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    best = np.full(len(xy), np.inf)
    for line in roads:
        a, b = line[:-1], line[1:]
        ab = b - a
        denom = np.maximum((ab**2).sum(1), 1e-12)
        t = np.clip(((xy[:, None, :] - a[None]) * ab[None]).sum(2) / denom[None], 0.0, 1.0)
        proj = a[None] + t[..., None] * ab[None]
        best = np.minimum(best, np.linalg.norm(xy[:, None, :] - proj, axis=2).min(1))
    return best
