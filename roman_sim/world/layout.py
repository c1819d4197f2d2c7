"""Placement: candidate positions per layout kind, then greedy acceptance with spacing.

Each layout proposes candidate (x, y, yaw) in priority order; ``Placer`` accepts a
candidate when its footprint disc stays inside the extent, off the road corridors and
``min_gap_m`` away from every accepted footprint (so nothing interpenetrates).
``regularity`` in [0, 1] scales the random jitter of positions and yaws (1 = exact lattice).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.registry import Registry
from roman_sim.world.roads import Polyline, distance_to_roads
from roman_sim.world.spec import LayoutSpec

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class LayoutContext:
    """What a layout needs to propose candidates."""

    extent: tuple[float, float]
    roads: list[Polyline]
    road_width_m: float
    spec: LayoutSpec
    regularity: float
    radius: float  # typical footprint radius of the family


Layout = Callable[[np.random.Generator, int, LayoutContext], tuple[F64, F64]]
LAYOUTS: Registry[Layout] = Registry("layout")


def _yaws(rng: np.random.Generator, base: F64, regularity: float) -> F64:
    return base + (1.0 - regularity) * rng.uniform(-np.pi, np.pi, len(base))


def _darts(rng: np.random.Generator, m: int, ctx: LayoutContext) -> F64:
    half = np.array(ctx.extent) / 2
    return rng.uniform(-half, half, (m, 2))


@LAYOUTS.register("uniform")
def uniform(rng: np.random.Generator, n: int, ctx: LayoutContext) -> tuple[F64, F64]:
    """Jittered square lattice of ``n`` cells, then random darts (fewer when regular)."""
    ex, ey = ctx.extent
    s = np.sqrt(ex * ey / max(n, 1))
    xs = np.arange(-ex / 2 + s / 2, ex / 2, s)
    ys = np.arange(-ey / 2 + s / 2, ey / 2, s)
    lattice = np.stack(np.meshgrid(xs, ys, indexing="xy"), -1).reshape(-1, 2)
    jitter = (1.0 - ctx.regularity) * rng.uniform(-s, s, lattice.shape)
    pts = (lattice + jitter)[rng.permutation(len(lattice))]
    pts = np.concatenate([pts, _darts(rng, int(3 * n * (1.0 - ctx.regularity)), ctx)])
    return pts, _yaws(rng, np.zeros(len(pts)), ctx.regularity)


@LAYOUTS.register("clustered")
def clustered(rng: np.random.Generator, n: int, ctx: LayoutContext) -> tuple[F64, F64]:
    """Gaussian patches around ``cluster_count`` random centres."""
    centres = _darts(rng, ctx.spec.cluster_count, ctx)
    m = 4 * n
    idx = rng.integers(0, len(centres), m)
    pts = centres[idx] + rng.normal(0.0, ctx.spec.cluster_radius_m / 2, (m, 2))
    return pts, _yaws(rng, np.zeros(m), ctx.regularity)


@LAYOUTS.register("rows")
def rows(rng: np.random.Generator, n: int, ctx: LayoutContext) -> tuple[F64, F64]:
    """Parallel rows along x, ``row_spacing_m`` apart; in-row pitch chosen to fit ``n``."""
    ex, ey = ctx.extent
    pitch = ctx.spec.row_spacing_m
    along = max(ex * ey / (max(n, 1) * pitch), 2 * ctx.radius + ctx.spec.min_gap_m)
    xs = np.arange(-ex / 2 + along / 2, ex / 2, along)
    ys = np.arange(-ey / 2 + pitch / 2, ey / 2, pitch)
    pts = np.stack(np.meshgrid(xs, ys, indexing="xy"), -1).reshape(-1, 2)
    jit = (1.0 - ctx.regularity) * np.array([0.3 * along, 0.15 * pitch])
    pts = pts + rng.uniform(-1.0, 1.0, pts.shape) * jit
    return pts, _yaws(rng, np.zeros(len(pts)), ctx.regularity)


def _roadside_slots(rng: np.random.Generator, step: float, ctx: LayoutContext) -> tuple[F64, F64]:
    """Slots every ``step`` metres along both sides of every road: centres (M, 2) and headings (M,)."""
    off = ctx.road_width_m / 2 + ctx.spec.roadside_offset_m + ctx.radius
    pts, heads = [], []
    for line in ctx.roads:
        seg = np.diff(line, axis=0)
        cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(seg, axis=1))])
        s = np.arange(step / 2, cum[-1], step)
        s = s + (1.0 - ctx.regularity) * rng.uniform(-0.3, 0.3, len(s)) * step
        k = np.clip(np.searchsorted(cum, s) - 1, 0, len(seg) - 1)
        heading = np.arctan2(seg[k, 1], seg[k, 0])
        base = line[k] + ((s - cum[k]) / np.maximum(cum[k + 1] - cum[k], 1e-9))[:, None] * seg[k]
        normal = np.stack([-np.sin(heading), np.cos(heading)], 1)
        for side in (1.0, -1.0):
            pts.append(base + side * off * normal)
            heads.append(heading)
    p, h = np.concatenate(pts), np.concatenate(heads)
    order = rng.permutation(len(p))
    return p[order], h[order]


@LAYOUTS.register("roadside")
def roadside(rng: np.random.Generator, n: int, ctx: LayoutContext) -> tuple[F64, F64]:
    """Both sides of every road, facing it, ``roadside_offset_m`` beyond the corridor edge.

    Evenly spaced slots come first; densely packed slots follow to fill what the even ones
    lose to crossings and neighbours.
    """
    if not ctx.roads:
        return uniform(rng, n, ctx)
    total = sum(float(np.linalg.norm(np.diff(r, axis=0), axis=1).sum()) for r in ctx.roads)
    tight = 2 * ctx.radius + ctx.spec.min_gap_m
    even_p, even_h = _roadside_slots(rng, max(2 * total / max(n, 1), tight), ctx)
    fill_p, fill_h = _roadside_slots(rng, tight, ctx)
    p, h = np.concatenate([even_p, fill_p]), np.concatenate([even_h, fill_h])
    return p, _yaws(rng, h, ctx.regularity)


class Placer:
    """Greedy acceptance of footprint discs (centre, radius) with a minimum gap."""

    def __init__(
        self, extent: tuple[float, float], roads: list[Polyline], road_width_m: float, gap: float, capacity: int
    ) -> None:
        self.half = np.array(extent, dtype=np.float64) / 2
        self.roads = roads
        self.road_half = road_width_m / 2
        self.gap = gap
        self.xy = np.zeros((capacity, 2))
        self.r = np.zeros(capacity)
        self.n = 0

    def feasible(self, pts: F64, radius: F64) -> NDArray[np.bool_]:
        """Static checks (inside extent, off roads) for centres (M, 2) with radii (M,)."""
        radius = np.asarray(radius, dtype=np.float64)
        inside = np.all(np.abs(pts) <= self.half - radius[..., None], axis=1)
        if self.roads and self.road_half > 0:
            inside &= distance_to_roads(pts, self.roads) >= self.road_half + radius
        return inside

    def try_add(self, p: F64, radius: float) -> bool:
        """Accept ``p`` if it keeps the gap to every accepted footprint."""
        if self.n >= len(self.r):
            return False
        if self.n:
            d = np.hypot(*(self.xy[: self.n] - p).T)
            if np.any(d < self.r[: self.n] + radius + self.gap):
                return False
        self.xy[self.n], self.r[self.n] = p, radius
        self.n += 1
        return True
