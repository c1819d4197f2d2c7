"""Robot paths: waypoint polylines routed around objects, smoothed and resampled.

``make_path`` turns a ``PathConfig`` into a ``Path2D``: a dense (K, 2) curve resampled at
constant arc length with headings. Kinds: ``loop`` (ellipse), ``out_and_back`` (straight
out, U-turn, back), ``lawnmower`` (boustrophedon), ``road`` (follow a world road),
``waypoints`` (user polyline), and the relations ``reverse_of`` / ``cross`` / ``retrace``
that derive a path from another robot's path (``retrace`` drives pieces of it, each forward
or backward, joined by routed connections: e.g. half the way along, half against). Straight
legs that would come closer than the clearance to an object are replaced by a grid-planned
detour; every final path is validated.

A revisit need not be a replay: ``start_fraction`` starts a robot elsewhere on its line, and
``lateral_offset_m`` moves it sideways within the road (geometry in ``revisit``), so two
robots on one road neither drive the same line nor place submaps at the same spots.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import SimError
from roman_sim.core.registry import Registry
from roman_sim.sim.planner import Obstacles, inside_world, route
from roman_sim.sim.revisit import offset_polyline, offset_range, start_at
from roman_sim.world.truth import WorldTruth

log = logging.getLogger(__name__)

PathKind = Literal["loop", "out_and_back", "lawnmower", "road", "waypoints", "reverse_of", "cross", "retrace"]


class PathConfig(StrictModel):
    """How to build one robot's path (fields unused by a kind are ignored).

    Generated shapes are placed at ``center`` (random inside the world when None).
    """

    kind: PathKind = "loop"
    center: tuple[float, float] | None = None
    radius_m: float = Field(8.0, gt=0.5, le=1000.0)
    aspect: float = Field(0.7, gt=0.1, le=1.0)
    length_m: float = Field(20.0, gt=1.0, le=10000.0)
    heading_deg: float | None = None
    width_m: float = Field(16.0, gt=1.0, le=1000.0)
    height_m: float = Field(12.0, gt=1.0, le=1000.0)
    spacing_m: float = Field(4.0, gt=0.5, le=100.0)
    road_index: int = Field(0, ge=0)
    waypoints: list[tuple[float, float]] = Field(default_factory=list)
    of: str | None = None
    heading_offset_deg: float = Field(90.0, ge=-180.0, le=180.0)
    at_fraction: float = Field(0.5, ge=0.0, le=1.0)
    pieces: list[tuple[float, float]] = Field(
        default_factory=lambda: [(0.0, 1.0)],
        description="retrace: (from, to) fractions of the other path; from > to drives it backwards",
    )
    clearance_m: float = Field(0.6, ge=0.0, le=10.0)
    edge_margin_m: float = Field(1.0, ge=0.0, le=100.0)
    resample_m: float = Field(0.05, gt=0.001, le=1.0)
    smooth_iterations: int = Field(3, ge=0, le=6)
    lateral_offset_m: tuple[float, float] | None = Field(
        None,
        description="road, waypoints, reverse_of, retrace: range (low, high) of this robot's sideways offset (m, "
        "positive to the left of its direction of travel) from the road's centre line or the followed robot's line "
        "before its own offset; drawn uniformly per robot (seeded); within the road width less the clearance",
    )
    start_fraction: float = Field(
        0.0,
        ge=0.0,
        lt=1.0,
        description="start this far along the line (fraction of its length): a closed line is driven whole from "
        "there, an open one from there to its end",
    )

    @field_validator("lateral_offset_m")
    @classmethod
    def _ordered(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not v[0] <= v[1]:
            raise ValueError(f"must be a range (low, high) with low <= high, got {list(v)}")
        return v


@dataclass(frozen=True)
class Path2D:
    """A dense planar path: points (K, 2) at constant arc-length spacing, headings (K,) rad.

    A path moved sideways (``PathConfig.lateral_offset_m``) keeps the line it was moved from
    as ``base`` and the drawn offset as ``offset_m`` (m, positive to the left).
    """

    xy: NDArray[np.float64]
    heading: NDArray[np.float64]
    s: NDArray[np.float64]
    base: Path2D | None = None
    offset_m: float = 0.0

    @property
    def length(self) -> float:
        """Total arc length (m)."""
        return float(self.s[-1])

    def at(self, s: float) -> tuple[float, float, float]:
        """(x, y, heading) at arc length ``s`` (clamped to the path)."""
        s = min(max(float(s), 0.0), self.length)
        i = min(max(int(np.searchsorted(self.s, s)) - 1, 0), len(self.s) - 2)
        s0, s1 = float(self.s[i]), float(self.s[i + 1])
        a = (s - s0) / max(s1 - s0, 1e-12)
        (x0, y0), (x1, y1) = self.xy[i].tolist(), self.xy[i + 1].tolist()
        return x0 + a * (x1 - x0), y0 + a * (y1 - y0), float(self.heading[i])


def path_from_points(pts: NDArray[np.float64], step_m: float) -> Path2D:
    """Resample a polyline (N, 2) at constant arc length ``step_m``; headings from tangents."""
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9])
    pts = pts[keep]
    if len(pts) < 2:
        raise SimError("path: needs at least two distinct points")
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    n = max(2, int(np.ceil(cum[-1] / step_m)) + 1)
    s = np.linspace(0.0, cum[-1], n)
    xy = np.column_stack([np.interp(s, cum, pts[:, 0]), np.interp(s, cum, pts[:, 1])])
    d = np.gradient(xy, axis=0)
    return Path2D(xy=xy, heading=np.arctan2(d[:, 1], d[:, 0]), s=s)


def reversed_path(path: Path2D) -> Path2D:
    """The same curve driven in the opposite direction."""
    return path_from_points(path.xy[::-1], float(path.s[1] - path.s[0]) if len(path.s) > 1 else 0.05)


def crossing_path(path: Path2D, heading_offset_deg: float, at_fraction: float, length_m: float = 20.0) -> Path2D:
    """A straight path through ``path.at(at_fraction * length)`` at heading + offset."""
    x, y, h = path.at(at_fraction * path.length)
    hh = h + np.radians(heading_offset_deg)
    u = np.array([np.cos(hh), np.sin(hh)])
    c = np.array([x, y])
    return path_from_points(np.vstack([c - u * length_m / 2, c + u * length_m / 2]), 0.05)


def retrace_path(other: Path2D, cfg: PathConfig, truth: WorldTruth, name: str, obs: Obstacles) -> Path2D:
    """Pieces of ``other`` (fractions ``cfg.pieces``) in order, joined by routed connections."""
    step = float(other.s[1] - other.s[0]) if len(other.s) > 1 else cfg.resample_m
    parts: list[NDArray[np.float64]] = []
    for k, (f0, f1) in enumerate(cfg.pieces):
        if not (0.0 <= f0 <= 1.0 and 0.0 <= f1 <= 1.0) or abs(f1 - f0) * other.length < 1.0:
            raise SimError(
                f"robot {name!r}: path.pieces[{k}]={[f0, f1]} must be fractions in [0, 1] spanning at least 1 m"
            )
        lo, hi = sorted((f0, f1))
        sel = other.xy[(other.s >= lo * other.length) & (other.s <= hi * other.length)]
        piece = sel if f1 > f0 else sel[::-1]
        if parts and np.linalg.norm(parts[-1][-1] - piece[0]) > 1e-6:
            join = route(np.vstack([parts[-1][-1], piece[0]]), truth, cfg.clearance_m, cfg.edge_margin_m, name, obs)
            parts.append(_smooth_clear(join, cfg, obs)[1:-1])
        parts.append(piece)
    return path_from_points(np.vstack(parts), step)


def _smooth_clear(poly: NDArray[np.float64], cfg: PathConfig, obs: Obstacles) -> NDArray[np.float64]:
    """The most smoothing of ``poly`` that keeps the clearance (none at worst)."""
    for it in range(cfg.smooth_iterations, 0, -1):
        cand = chaikin(poly, it)
        dense = path_from_points(cand, cfg.resample_m).xy if len(cand) > 1 else cand
        if obs.clearance(dense).min() >= cfg.clearance_m:
            return cand
    return poly


def chaikin(pts: NDArray[np.float64], iterations: int) -> NDArray[np.float64]:
    """Chaikin corner cutting (end points kept): a smooth curve inside the polyline's hull."""
    for _ in range(iterations):
        if len(pts) < 3:
            break
        a, b = pts[:-1], pts[1:]
        q, r = 0.75 * a + 0.25 * b, 0.25 * a + 0.75 * b
        pts = np.vstack([pts[:1], np.column_stack([q, r]).reshape(-1, 2)[1:-1], pts[-1:]])
    return pts


def _centre(cfg: PathConfig, truth: WorldTruth, rng: np.random.Generator, half: float) -> NDArray[np.float64]:
    if cfg.center is not None:
        return np.asarray(cfg.center, dtype=np.float64)
    ter = truth.terrain
    lim = np.array([ter.size_x / 2, ter.size_y / 2]) - cfg.edge_margin_m - half
    return rng.uniform(-np.maximum(lim, 0.0), np.maximum(lim, 0.0))


def _heading(cfg: PathConfig, rng: np.random.Generator) -> float:
    return np.radians(cfg.heading_deg) if cfg.heading_deg is not None else float(rng.uniform(-np.pi, np.pi))


WaypointGen = Callable[[PathConfig, WorldTruth, np.random.Generator], NDArray[np.float64]]
WAYPOINTS: Registry[WaypointGen] = Registry("path kind")


@WAYPOINTS.register("loop")
def _loop(cfg: PathConfig, truth: WorldTruth, rng: np.random.Generator) -> NDArray[np.float64]:
    c, h = _centre(cfg, truth, rng, cfg.radius_m), _heading(cfg, rng)
    a = np.linspace(0.0, 2 * np.pi, 25)
    local = np.column_stack([cfg.radius_m * np.cos(a), cfg.aspect * cfg.radius_m * np.sin(a)])
    R = np.array([[np.cos(h), -np.sin(h)], [np.sin(h), np.cos(h)]])
    return c + local @ R.T


@WAYPOINTS.register("out_and_back")
def _out_and_back(cfg: PathConfig, truth: WorldTruth, rng: np.random.Generator) -> NDArray[np.float64]:
    c, h = _centre(cfg, truth, rng, cfg.length_m / 2), _heading(cfg, rng)
    u, n = np.array([np.cos(h), np.sin(h)]), np.array([-np.sin(h), np.cos(h)])
    start, end = c - u * cfg.length_m / 2, c + u * cfg.length_m / 2
    turn = 1.0  # U-turn radius (m)
    a = np.linspace(-np.pi / 2, np.pi / 2, 9)
    arc = end + turn * n + np.outer(np.cos(a), u) * turn + np.outer(np.sin(a), n) * turn
    return np.vstack([start, arc, start + 2 * turn * n])


@WAYPOINTS.register("lawnmower")
def _lawnmower(cfg: PathConfig, truth: WorldTruth, rng: np.random.Generator) -> NDArray[np.float64]:
    c = _centre(cfg, truth, rng, max(cfg.width_m, cfg.height_m) / 2)
    h = np.radians(cfg.heading_deg or 0.0)
    rows = np.arange(-cfg.height_m / 2, cfg.height_m / 2 + 1e-9, cfg.spacing_m)
    pts = []
    for i, y in enumerate(rows):
        xs = (-cfg.width_m / 2, cfg.width_m / 2)[:: 1 if i % 2 == 0 else -1]
        pts += [(xs[0], y), (xs[1], y)]
    R = np.array([[np.cos(h), -np.sin(h)], [np.sin(h), np.cos(h)]])
    return c + np.asarray(pts) @ R.T


@WAYPOINTS.register("road")
def _road(cfg: PathConfig, truth: WorldTruth, rng: np.random.Generator) -> NDArray[np.float64]:
    if cfg.road_index >= len(truth.roads):
        raise SimError(f"path.road_index {cfg.road_index}: the world has {len(truth.roads)} road(s)")
    return np.asarray(truth.roads[cfg.road_index], dtype=np.float64)[:, :2]


@WAYPOINTS.register("waypoints")
def _waypoints(cfg: PathConfig, truth: WorldTruth, rng: np.random.Generator) -> NDArray[np.float64]:
    if len(cfg.waypoints) < 2:
        raise SimError("path.waypoints: needs at least two (x, y) waypoints")
    return np.asarray(cfg.waypoints, dtype=np.float64)


def validate_path(
    path: Path2D, truth: WorldTruth, cfg: PathConfig, name: str, obstacles: Obstacles | None = None
) -> Path2D:
    """Return ``path`` if it stays inside the world and clear of objects, else raise ``SimError``."""
    out = ~inside_world(truth, path.xy, cfg.edge_margin_m)
    if out.any():
        x, y = path.xy[np.argmax(out)]
        raise SimError(
            f"robot {name!r}: path leaves the world at ({x:.2f}, {y:.2f}) (edge margin {cfg.edge_margin_m} m)"
        )
    clear = (obstacles or Obstacles(truth)).clearance(path.xy)
    if np.any(clear < cfg.clearance_m - 1e-6):
        i = int(np.argmin(clear))
        x, y = path.xy[i]
        raise SimError(
            f"robot {name!r}: path passes {max(clear[i], 0.0):.2f} m from an object at ({x:.2f}, {y:.2f}), "
            f"closer than its clearance {cfg.clearance_m} m"
        )
    return path


def make_path(
    cfg: PathConfig,
    truth: WorldTruth,
    rng: np.random.Generator,
    name: str = "robot",
    paths_by_name: Mapping[str, Path2D] | None = None,
    road_width_m: float | None = None,
) -> Path2D:
    """Build, route, smooth, resample and validate a path, then apply its start and lateral offset.

    Args:
        cfg: path configuration.
        truth: the world (terrain size, objects, roads).
        rng: seeded generator for random placement and the drawn lateral offset.
        name: robot name, used in error messages.
        paths_by_name: other robots' paths, for ``reverse_of``, ``cross`` and ``retrace``.
        road_width_m: the world's road width, which bounds ``lateral_offset_m`` (None: only
            the clearance to objects bounds it).

    Raises:
        SimError: no valid path exists (leaves the world, blocked, unknown ``of``, an offset
            off the road).
    """
    obs = Obstacles(truth)
    line = _line(cfg, truth, rng, name, paths_by_name, obs)
    if cfg.lateral_offset_m is not None and cfg.kind not in OFFSET_KINDS:
        raise SimError(
            f"robot {name!r}: path.lateral_offset_m applies to {', '.join(OFFSET_KINDS)} paths, not {cfg.kind}"
        )
    if cfg.start_fraction > 0.0:
        line = validate_path(
            path_from_points(start_at(line.xy, cfg.start_fraction), cfg.resample_m), truth, cfg, name, obs
        )
    if cfg.lateral_offset_m is None:
        return line
    lo, hi = offset_range(cfg.lateral_offset_m, road_width_m, cfg.clearance_m, name)
    d = float(rng.uniform(lo, hi)) if hi > lo else lo
    moved = path_from_points(offset_polyline(line.xy, line.heading, d), cfg.resample_m)
    return replace(validate_path(moved, truth, cfg, name, obs), base=line, offset_m=d)


def _line(
    cfg: PathConfig,
    truth: WorldTruth,
    rng: np.random.Generator,
    name: str,
    paths_by_name: Mapping[str, Path2D] | None,
    obs: Obstacles,
) -> Path2D:
    """The validated line of ``cfg.kind``, before the robot's own start and offset."""
    if cfg.kind in ("reverse_of", "cross", "retrace"):
        other = (paths_by_name or {}).get(cfg.of or "")
        if other is None:
            known = ", ".join(sorted(paths_by_name or {})) or "none"
            raise SimError(f"robot {name!r}: path.of={cfg.of!r} is not an earlier robot (known: {known})")
        if cfg.lateral_offset_m is not None and other.base is not None:
            other = other.base  # an offset is measured from the line the other robot was moved from
        if cfg.kind == "reverse_of":
            return validate_path(reversed_path(other), truth, cfg, name, obs)
        if cfg.kind == "retrace":
            return validate_path(retrace_path(other, cfg, truth, name, obs), truth, cfg, name, obs)
        line = crossing_path(other, cfg.heading_offset_deg, cfg.at_fraction, cfg.length_m).xy
        waypoints = _clip_line(line[[0, -1]], truth, cfg.edge_margin_m)
        routed = route(waypoints, truth, cfg.clearance_m, cfg.edge_margin_m, name, obs)
        return _smooth_valid(routed, truth, cfg, name, obs)
    gen = WAYPOINTS.get(cfg.kind)
    # Randomly placed shapes are re-drawn a few times if a placement cannot be routed.
    attempts = _RANDOM_ATTEMPTS if cfg.center is None and cfg.kind in _RANDOM_KINDS else 1
    for k in range(attempts):
        try:
            routed = route(gen(cfg, truth, rng), truth, cfg.clearance_m, cfg.edge_margin_m, name, obs)
            return _smooth_valid(routed, truth, cfg, name, obs)
        except SimError as err:
            if k == attempts - 1:
                raise
            log.debug("robot %s: placement %d rejected (%s)", name, k, err)
    raise AssertionError("unreachable")


_RANDOM_KINDS = ("loop", "out_and_back", "lawnmower")
#: Kinds that follow a road or another robot's line, and so may be moved sideways within it.
OFFSET_KINDS = ("road", "waypoints", "reverse_of", "retrace")
_RANDOM_ATTEMPTS = 20


def _smooth_valid(poly: NDArray[np.float64], truth: WorldTruth, cfg: PathConfig, name: str, obs: Obstacles) -> Path2D:
    """Smooth as much as the clearance allows (fewer Chaikin iterations if needed)."""
    for it in range(cfg.smooth_iterations, -1, -1):
        try:
            return validate_path(path_from_points(chaikin(poly, it), cfg.resample_m), truth, cfg, name, obs)
        except SimError:
            if it == 0:
                raise
    raise AssertionError("unreachable")


def _clip_line(ends: NDArray[np.float64], truth: WorldTruth, margin: float) -> NDArray[np.float64]:
    """Shorten the segment ``ends`` (2, 2) symmetrically-free so both ends lie in the world."""
    a, b = ends
    half = np.array([truth.terrain.size_x / 2, truth.terrain.size_y / 2]) - margin
    ts = np.linspace(0.0, 1.0, 201)
    pts = a + ts[:, None] * (b - a)
    ok = np.all(np.abs(pts) <= half, axis=1)
    if ok.sum() < 2:
        raise SimError("cross path: the crossing line does not fit inside the world")
    idx = np.flatnonzero(ok)
    return pts[[idx[0], idx[-1]]]
