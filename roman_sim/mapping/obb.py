"""Minimum-volume oriented box extents: trimesh's ``oriented_bounds``, bit for bit, in fewer calls.

``trimesh.bounds.oriented_bounds`` tries one box direction per (rounded) convex-hull face
normal, about a hundred per segment, each with a dozen numpy calls and a rotation matrix
built in Python: the loop costs twice the hull. ``oriented_extents`` computes the same hull
and the same candidate directions, then screens all directions at once (the box volume
along a direction does not depend on the in-plane basis, so any orthonormal one will do)
and repeats trimesh's exact per-direction arithmetic only for the directions whose screened
volume is within a rounding margin of the smallest, plus any whose silhouette test is too
close to its threshold to trust. The first direction of smallest exact volume, in trimesh's
order, is trimesh's choice; its box is then computed by trimesh's own code. Anything unusual
(qhull failures, empty silhouettes, non-finite values) runs trimesh itself, so the result is
always trimesh's (tests/mapping/test_obb.py compares them).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from trimesh import bounds, convex, grouping, transformations, util

F64 = NDArray[np.float64]
_EPS = np.finfo(np.float64).eps


def trimesh_extents(points: F64) -> F64:
    """Extents of ``trimesh.bounds.oriented_bounds(points)`` (the reference)."""
    return np.asarray(bounds.oriented_bounds(points)[1], dtype=np.float64)


def oriented_extents(points: F64) -> F64:
    """The extents ``trimesh.bounds.oriented_bounds(points)`` gives (in some order); same errors."""
    try:
        hull = convex.convex_hull(points, repair=True)
        found = _fast(hull)
    except Exception:  # qhull's failures and any corner case: trimesh decides (and may raise)
        found = None
    return trimesh_extents(points) if found is None else found


def _directions(hull_normals: F64) -> tuple[F64, F64]:
    """trimesh's candidate box directions: unit normals and their spherical coordinates."""
    spherical = util.vector_to_spherical(util.vector_hemisphere(hull_normals))
    unique = grouping.unique_rows(spherical, digits=1)[0]
    return util.spherical_to_vector(spherical[unique]), spherical[unique]


def _fast(hull: object) -> F64 | None:
    """The extents for ``hull`` (a trimesh convex hull), or None when trimesh must decide."""
    vertices = np.asarray(hull.vertices, dtype=np.float64)  # type: ignore[attr-defined]
    adj = hull.face_adjacency.T  # type: ignore[attr-defined]
    edges = hull.face_adjacency_edges  # type: ignore[attr-defined]
    face_normals = hull.face_normals  # type: ignore[attr-defined]
    if not np.all(np.isfinite(vertices)):
        return None
    normals, spherical = _directions(face_normals)
    volume, check = _screen(vertices, face_normals, adj, edges, normals)
    if volume is None:
        return None
    scale = float(np.ptp(vertices, axis=0).max())
    margin = 1e3 * _EPS * (float(np.abs(vertices).max()) + scale) * scale**2
    best = np.nanmin(np.where(check, np.inf, volume)) if (~check).any() else np.inf
    todo = np.flatnonzero(check | (volume <= best + 1e-6 * abs(best) + margin))
    min_volume, min_2D = np.inf, None
    for d in todo:  # trimesh's loop, in its order, on the candidates only
        to_2D = transformations.spherical_matrix(*spherical[d]).T
        v = _exact_volume(vertices, face_normals, adj, edges, normals[d], to_2D)
        if v is not None and v < min_volume:
            min_volume, min_2D = v, to_2D
    return None if min_2D is None else _box(vertices, min_2D)


def _exact_volume(
    vertices: F64, hull_normals: F64, hull_adj: NDArray, hull_edge: NDArray, normal: F64, to_2D: F64
) -> float | None:
    """Box volume along one direction, as trimesh computes it (None: trimesh skips it)."""
    side = np.dot(hull_normals, normal) > -1e-10
    if not side.any():
        return None
    edges = hull_edge[np.bitwise_xor(*side[hull_adj])]
    projected = np.dot(to_2D[:3, :3], vertices.T).T[:, :3]
    edge_vert = projected[:, :2][edges]
    edge_vectors = edge_vert[:, 1, :] - edge_vert[:, 0, :]
    edge_norm = np.sqrt(np.dot(edge_vectors**2, [1, 1]))
    edge_nonzero = edge_norm > 1e-10
    edge_vectors = edge_vectors[edge_nonzero] / edge_norm[edge_nonzero].reshape((-1, 1))
    perp_vectors = np.fliplr(edge_vectors) * [-1.0, 1.0]
    x = np.dot(edge_vectors, edge_vert[:, 0, :2].T)
    y = np.dot(perp_vectors, edge_vert[:, 0, :2].T)
    area = ((x.max(axis=1) - x.min(axis=1)) * (y.max(axis=1) - y.min(axis=1))).min()
    return float(area * np.ptp(projected[:, 2]))


def _box(vertices: F64, min_2D: F64) -> F64:
    """The box extents along the chosen direction (trimesh's final step)."""
    vert_ones = np.column_stack((vertices, np.ones(len(vertices)))).T
    projected = np.dot(min_2D, vert_ones).T[:, :3]
    height = np.ptp(projected[:, 2])
    _, box = bounds.oriented_bounds_2D(projected[:, :2])
    return np.append(box, height)


def _plane_basis(normals: F64) -> tuple[F64, F64]:
    """Two unit vectors spanning the plane normal to each of ``normals`` (D, 3)."""
    helper = np.where(np.abs(normals[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    a = np.cross(normals, helper)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    return a, np.cross(normals, a)


def _screen(
    vertices: F64, face_normals: F64, adj: NDArray, edges: NDArray, normals: F64
) -> tuple[F64 | None, NDArray[np.bool_]]:
    """Approximate box volume along every direction, and the directions to recheck exactly.

    A direction is rechecked when a face's silhouette test or an edge's length test lies
    within rounding of trimesh's threshold. The volume is None when trimesh would fail on a
    direction (an empty silhouette), so that trimesh itself runs.
    """
    n_dir = len(normals)
    dots = face_normals @ normals.T  # (faces, directions)
    check = (np.abs(dots + 1e-10) < 1e-12).any(axis=0)
    side = dots > -1e-10
    skipped = ~side.any(axis=0)
    d_idx, a_idx = np.nonzero((side[adj[0]] ^ side[adj[1]]).T)  # silhouette edges, direction by direction
    u, w = _plane_basis(normals)
    pu, pw = vertices @ u.T, vertices @ w.T  # (vertices, directions) in-plane coordinates
    e0, e1 = edges[a_idx, 0], edges[a_idx, 1]
    vec = np.stack([pu[e1, d_idx] - pu[e0, d_idx], pw[e1, d_idx] - pw[e0, d_idx]], axis=1)
    start = np.stack([pu[e0, d_idx], pw[e0, d_idx]], axis=1)
    norm = np.hypot(vec[:, 0], vec[:, 1])
    near = np.abs(norm - 1e-10) < 1e-11 + 100 * _EPS * float(np.abs(vertices).max())
    check |= np.bincount(d_idx[near], minlength=n_dir) > 0
    valid = norm > 1e-10
    n_valid = np.bincount(d_idx[valid], minlength=n_dir)
    if ((n_valid == 0) & ~skipped & ~check).any():
        return None, check  # trimesh raises on this direction (reduction of an empty array)
    area = _min_areas(vec / np.where(valid, norm, 1.0)[:, None], valid, start, d_idx, n_dir)
    height = np.ptp(vertices @ normals.T, axis=0)
    volume = np.where(skipped, np.inf, area * height)
    return volume, check | (~skipped & ~np.isfinite(volume))


def _min_areas(unit: F64, valid: NDArray[np.bool_], start: F64, dirs: NDArray, n_dir: int) -> F64:
    """Per direction, the smallest rectangle over its valid edge directions ``unit`` bounding its
    edges' start points (edges grouped by direction, ``dirs`` ascending)."""
    counts = np.bincount(dirs, minlength=n_dir)
    rank = np.arange(len(dirs)) - np.repeat(np.cumsum(counts) - counts, counts)
    width = max(int(counts.max(initial=0)), 1)
    pts = np.zeros((n_dir, width, 2))
    pts[dirs, rank] = start
    pad = np.arange(width)[None, :] >= counts[:, None]  # padding repeats each direction's first point
    pts[pad] = np.broadcast_to(pts[:, :1], pts.shape)[pad]
    axes = np.zeros((n_dir, width, 2))
    axes[dirs, rank] = unit
    ok = np.zeros((n_dir, width), dtype=bool)
    ok[dirs, rank] = valid
    a0, a1 = np.ascontiguousarray(axes[..., 0]), np.ascontiguousarray(axes[..., 1])
    px, py = pts[..., 0].T[:, :, None], pts[..., 1].T[:, :, None]  # points first: fast reductions
    x, y = a0 * px + a1 * py, a0 * py - a1 * px  # (points, directions, edges)
    rect = (x.max(axis=0) - x.min(axis=0)) * (y.max(axis=0) - y.min(axis=0))
    return np.where(ok, rect, np.inf).min(axis=1, initial=np.inf)
