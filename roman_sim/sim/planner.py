"""Collision checks against object footprints and a grid planner that routes around them.

Objects are discs in the ground plane (``ObjectTruth.radius`` around the object origin).
A point is free when it is at least ``clearance_m`` away from every disc.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from roman_sim.core.errors import SimError
from roman_sim.world.query import footprints
from roman_sim.world.truth import WorldTruth

log = logging.getLogger(__name__)

_K_NEAREST = 16


class Obstacles:
    """Object footprints of a world as discs, with a KD-tree for clearance queries.

    Unlike ``roman_sim.world.query.clearance`` (exact, one query per point) this keeps the
    tree and answers many points at once from the 16 nearest footprint centres, which is
    what path checks and planning grids need.
    """

    def __init__(self, truth: WorldTruth) -> None:
        self.truth = truth
        self.xy, self.r = footprints(truth)
        self.tree = cKDTree(self.xy) if len(self.xy) else None

    def clearance(self, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        """(N,) distance from each point (N, 2) to the nearest object footprint (inf if none)."""
        pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
        if self.tree is None:
            return np.full(len(pts), np.inf)
        k = min(_K_NEAREST, len(self.xy))
        d, idx = self.tree.query(pts, k=k)
        d, idx = d.reshape(len(pts), k), idx.reshape(len(pts), k)
        return np.min(d - self.r[idx], axis=1)

    def segment_free(
        self, a: NDArray[np.float64], b: NDArray[np.float64], clearance_m: float, step: float = 0.1
    ) -> bool:
        """Whether the straight segment a -> b keeps ``clearance_m`` from every object."""
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
        pts = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
        return bool(np.all(self.clearance(pts) >= clearance_m))


class GridPlanner:
    """8-connected shortest paths on a free-space grid (cells at least ``clearance_m`` free).

    Args:
        obstacles: object footprints.
        clearance_m: required distance from objects.
        margin_m: distance to keep from the world edge.
        resolution_m: grid cell size.
    """

    def __init__(self, obstacles: Obstacles, clearance_m: float, margin_m: float, resolution_m: float = 0.25) -> None:
        ter = obstacles.truth.terrain
        self.res = resolution_m
        self.x0, self.y0 = -ter.size_x / 2 + margin_m, -ter.size_y / 2 + margin_m
        self.nx = max(2, int((ter.size_x - 2 * margin_m) / resolution_m) + 1)
        self.ny = max(2, int((ter.size_y - 2 * margin_m) / resolution_m) + 1)
        gx, gy = np.meshgrid(self.x0 + np.arange(self.nx) * self.res, self.y0 + np.arange(self.ny) * self.res)
        self.centres = np.column_stack([gx.ravel(), gy.ravel()])
        self.free = obstacles.clearance(self.centres) >= clearance_m + 0.5 * self.res
        self.graph = self._build_graph()

    def _build_graph(self) -> coo_matrix:
        idx = np.arange(self.nx * self.ny).reshape(self.ny, self.nx)
        rows, cols, w = [], [], []
        for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
            a = idx[: self.ny - dy, max(0, -dx) : self.nx - max(0, dx)]
            b = idx[dy:, max(0, dx) : self.nx - max(0, -dx)]
            ok = self.free[a] & self.free[b]
            rows.append(a[ok])
            cols.append(b[ok])
            w.append(np.full(int(ok.sum()), self.res * np.hypot(dx, dy)))
        r, c, ww = np.concatenate(rows), np.concatenate(cols), np.concatenate(w)
        n = self.nx * self.ny
        return coo_matrix((ww, (r, c)), shape=(n, n)).tocsr()

    def nearest_free(self, p: NDArray[np.float64], max_dist_m: float) -> NDArray[np.float64] | None:
        """Centre of the free cell nearest to ``p`` within ``max_dist_m``, or None."""
        d = np.linalg.norm(self.centres - p, axis=1)
        d[~self.free] = np.inf
        i = int(np.argmin(d))
        return self.centres[i] if d[i] <= max_dist_m else None

    def _cell(self, p: NDArray[np.float64]) -> int:
        j = int(np.clip(np.rint((p[0] - self.x0) / self.res), 0, self.nx - 1))
        i = int(np.clip(np.rint((p[1] - self.y0) / self.res), 0, self.ny - 1))
        return i * self.nx + j

    def _free_cell(self, p: NDArray[np.float64]) -> int | None:
        """Grid cell of ``p``, or the nearest free cell within two cells when it is blocked."""
        c = self._cell(p)
        if self.free[c]:
            return c
        q = self.nearest_free(p, 2.0 * self.res)
        return None if q is None else self._cell(q)

    def plan(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """Free polyline (K, 2) from ``a`` to ``b`` (both should be free), or None if none exists."""
        s, g = self._free_cell(a), self._free_cell(b)
        if s is None or g is None:
            return None
        dist, pred = dijkstra(self.graph, directed=False, indices=s, return_predecessors=True)
        if not np.isfinite(dist[g]):
            return None
        chain = [g]
        while chain[-1] != s:
            chain.append(int(pred[chain[-1]]))
        return np.vstack([a, self.centres[chain[::-1]][1:-1], b])


def inside_world(truth: WorldTruth, pts: NDArray[np.float64], margin: float) -> NDArray[np.bool_]:
    """(N,) whether points (N, 2) lie inside the terrain with ``margin`` to spare."""
    ter = truth.terrain
    return (np.abs(pts[:, 0]) <= ter.size_x / 2 - margin + 1e-9) & (np.abs(pts[:, 1]) <= ter.size_y / 2 - margin + 1e-9)


def _shortcut(pts: NDArray[np.float64], obs: Obstacles, clearance: float) -> NDArray[np.float64]:
    out, i = [pts[0]], 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not obs.segment_free(pts[i], pts[j], clearance):
            j -= 1
        out.append(pts[j])
        i = j
    return np.asarray(out)


def route(
    waypoints: NDArray[np.float64],
    truth: WorldTruth,
    clearance_m: float,
    edge_margin_m: float,
    name: str,
    obs: Obstacles,
) -> NDArray[np.float64]:
    """Polyline through ``waypoints`` with detours around objects (grid planner when needed)."""
    out = ~inside_world(truth, waypoints, edge_margin_m)
    if out.any():
        x, y = waypoints[np.argmax(out)]
        raise SimError(f"robot {name!r}: path waypoint ({x:.2f}, {y:.2f}) lies outside the world")
    need = clearance_m + 0.2  # slack so smoothing keeps the clearance
    planner: GridPlanner | None = None
    pts = waypoints.copy()
    blocked = obs.clearance(pts) < need
    legs_blocked = [not obs.segment_free(a, b, need) for a, b in zip(pts[:-1], pts[1:])]
    if blocked.any() or any(legs_blocked):
        planner = GridPlanner(obs, need, edge_margin_m)
    for i in np.flatnonzero(blocked):
        snapped = planner.nearest_free(pts[i], 5.0) if planner else None
        if snapped is None:
            raise SimError(f"robot {name!r}: waypoint ({pts[i, 0]:.2f}, {pts[i, 1]:.2f}) is blocked by objects")
        pts[i] = snapped
    poly = [pts[:1]]
    for a, b in zip(pts[:-1], pts[1:]):
        if planner is None or obs.segment_free(a, b, need):
            poly.append(b[None])
            continue
        leg = planner.plan(a, b)
        if leg is None:
            raise SimError(f"robot {name!r}: no free route from ({a[0]:.1f}, {a[1]:.1f}) to ({b[0]:.1f}, {b[1]:.1f})")
        poly.append(_shortcut(leg, obs, need)[1:])
    return np.vstack(poly)
