"""``Segment``: one tracked 3D object hypothesis in the robot's odometry frame.

Keeps voxel-downsampled points, sighting times, a count-weighted running-mean semantic
descriptor and, for evaluation only, how many of its observed points came from each true
object. Shape features are computed lazily and cached.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from roman_sim.core.geometry import pca_shape_features
from roman_sim.mapping.obb import oriented_extents
from roman_sim.mapping.voxels import NEIGHBOUR_OFFSETS as _NEIGHBOUR_OFFSETS
from roman_sim.mapping.voxels import downsample, downsample_union, hash_voxels, neighbour_pairs, pack_cells, voxel_set

log = logging.getLogger(__name__)


class Status(str, Enum):
    """Lifecycle of a segment."""

    NURSERY = "nursery"
    ACTIVE = "active"
    INACTIVE = "inactive"
    FINISHED = "finished"


def obb_extents(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """Oriented-box extents (sorted descending) and volume; volume 0 with <= 4 points.

    Uses trimesh's minimum-volume oriented box (``roman_sim.mapping.obb``: the same bits in
    fewer calls); degenerate (flat) point sets fall back to the PCA-aligned box.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) <= 4:
        ext = pca_extents(pts)
        return ext, 0.0
    try:
        ext = np.sort(oriented_extents(pts))[::-1]
    except Exception:  # qhull fails on exactly flat or collinear sets
        ext = pca_extents(pts)
    return ext, float(np.prod(ext))


def pca_extents(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Extents of the PCA-aligned bounding box, sorted descending (cheap OBB proxy)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) < 2:
        return np.zeros(3)
    c = pts - pts.mean(axis=0)
    _, vecs = np.linalg.eigh(c.T @ c)
    proj = c @ vecs
    return np.sort(proj.max(axis=0) - proj.min(axis=0))[::-1]


def largest_cluster(points: NDArray[np.float64], eps: float) -> NDArray[np.float64]:
    """Points of the largest spatial cluster at scale ``eps``.

    Points are binned into voxels of size ``eps`` and clusters are the 26-connected
    components of the occupied voxels: points closer than ``eps`` always share a cluster
    (a slightly coarser cut than single-linkage on points, and far cheaper on dense clouds).
    The voxels are packed int64 keys (sorted like the rows of ``np.unique(axis=0)``) and their
    neighbours are found by key; ``largest_cluster_reference`` builds the same graph with a
    k-d tree (ties between equal clusters go to the same one).
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) < 2:
        return pts
    packed = pack_cells(np.floor(pts / eps).astype(np.int64))
    if packed is None:
        return largest_cluster_reference(pts, eps)
    keys, inv = np.unique(packed, return_inverse=True)
    if len(keys) == 1:
        return pts
    return _largest(pts, inv.reshape(-1), len(keys), *neighbour_pairs(keys))


def largest_cluster_reference(points: NDArray[np.float64], eps: float) -> NDArray[np.float64]:
    """``largest_cluster`` with ``np.unique(axis=0)`` and ``cKDTree.query_pairs`` (any coordinates)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) < 2:
        return pts
    keys, inv = np.unique(np.floor(pts / eps).astype(np.int64), axis=0, return_inverse=True)
    if len(keys) == 1:
        return pts
    pairs = cKDTree(keys).query_pairs(np.sqrt(3.0) + 1e-6, output_type="ndarray")
    return _largest(pts, inv.reshape(-1), len(keys), pairs[:, 0], pairs[:, 1])


def _largest(
    pts: NDArray[np.float64], inv: NDArray[np.int64], n: int, i: NDArray[np.int64], j: NDArray[np.int64]
) -> NDArray[np.float64]:
    """The points of the largest connected component of the voxel graph (edges i-j)."""
    graph = coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    point_labels = labels[inv]
    counts = np.bincount(point_labels)
    return pts[point_labels == int(np.argmax(counts))]


def contained_fraction(points: NDArray[np.float64], other: "Segment", dist: float) -> float:
    """Fraction of ``points`` whose voxel (size ``dist``) touches one of ``other``'s voxels.

    Every point within ``dist`` of ``other`` counts (a 26-neighbourhood test on packed keys).
    """
    if len(points) == 0 or len(other.points) == 0:
        return 0.0
    big = other.voxels(dist)
    keys = hash_voxels(points, dist)
    q = (keys[None, :] + _NEIGHBOUR_OFFSETS[:, None]).ravel()  # all 27 neighbours in one search
    idx = np.minimum(np.searchsorted(big, q), len(big) - 1)
    hit = (big[idx] == q).reshape(len(_NEIGHBOUR_OFFSETS), len(keys)).any(axis=0)
    return float(hit.mean())


@dataclass(eq=False)
class Segment:
    """A tracked object hypothesis (points in the odometry frame).

    Attributes:
        id: segment id, unique within one robot's map.
        points: (N, 3) voxel-downsampled points in the odometry frame.
        first_seen, last_seen: times (s) of the first and latest sighting.
        num_sightings: number of observations merged in.
        descriptor_sum: sum of the unit embeddings (the mean is its normalisation).
        truth_counts: evaluation only: observed points per true object id (-1 = none).
        status: lifecycle state.
    """

    id: int
    points: NDArray[np.float64]
    first_seen: float
    last_seen: float
    num_sightings: int = 1
    descriptor_sum: NDArray[np.float64] | None = None
    truth_counts: Counter = field(default_factory=Counter)
    status: Status = Status.NURSERY
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    # ---- updates -------------------------------------------------------------------
    def set_points(self, points: NDArray[np.float64], voxel: float) -> None:
        """Replace the points (voxel-downsampled at ``voxel``) and drop cached features."""
        self._set_downsampled(downsample(points, voxel))

    def _set_downsampled(self, points: NDArray[np.float64]) -> None:
        self.points = points
        self._cache.clear()

    def _merge_points(self, points: NDArray[np.float64], voxel: float) -> None:
        """Downsample this segment's points with ``points`` (voxel keys kept for the next merge)."""
        merged, keys = downsample_union(self.points, points, voxel, self._cache.get(("keys", voxel)))
        self._set_downsampled(merged)
        if keys is not None:
            self._cache[("keys", voxel)] = keys

    def add_observation(
        self, points: NDArray[np.float64], t: float, descriptor: NDArray | None, truth: Counter, voxel: float
    ) -> None:
        """Fuse one observation (points in the odometry frame) into this segment."""
        self._merge_points(points, voxel)
        self.first_seen = min(self.first_seen, t)
        self.last_seen = max(self.last_seen, t)
        self.num_sightings += 1
        self._add_descriptor(descriptor, 1.0)
        self.truth_counts.update(truth)

    def absorb(self, other: "Segment", voxel: float) -> None:
        """Merge ``other`` into this segment (this id is kept)."""
        self._merge_points(other.points, voxel)
        self.first_seen = min(self.first_seen, other.first_seen)
        self.last_seen = max(self.last_seen, other.last_seen)
        self.num_sightings += other.num_sightings
        if other.descriptor_sum is not None:
            self._add_descriptor(other.descriptor_sum, 1.0)
        self.truth_counts.update(other.truth_counts)

    def _add_descriptor(self, d: NDArray | None, weight: float) -> None:
        if d is None:
            return
        d = np.asarray(d, dtype=np.float64) * weight
        self.descriptor_sum = d.copy() if self.descriptor_sum is None else self.descriptor_sum + d

    def keep_largest_cluster(self, eps: float) -> None:
        """Cleanup: keep only the largest spatial cluster of points."""
        kept = largest_cluster(self.points, eps)
        if len(kept) != len(self.points):
            self.points = kept
            self._cache.clear()

    # ---- features ------------------------------------------------------------------
    @property
    def descriptor(self) -> NDArray[np.float32] | None:
        """Unit running-mean descriptor (None when no embedding was seen)."""
        if self.descriptor_sum is None:
            return None
        n = np.linalg.norm(self.descriptor_sum)
        return (self.descriptor_sum / n if n > 0 else self.descriptor_sum).astype(np.float32)

    @property
    def center(self) -> NDArray[np.float64]:
        """Mean point (odometry frame; cached)."""
        if "center" not in self._cache:
            self._cache["center"] = self.points.mean(axis=0) if len(self.points) else np.full(3, np.nan)
        return self._cache["center"]

    @property
    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Axis-aligned (min, max) corners of the points (odometry frame)."""
        if "bounds" not in self._cache:
            self._cache["bounds"] = (
                (self.points.min(axis=0), self.points.max(axis=0))
                if len(self.points)
                else (np.full(3, np.inf), np.full(3, -np.inf))
            )
        return self._cache["bounds"]

    def _obb(self) -> tuple[NDArray[np.float64], float]:
        if "obb" not in self._cache:
            self._cache["obb"] = obb_extents(self.points)
        return self._cache["obb"]

    @property
    def extents(self) -> NDArray[np.float64]:
        """Oriented-box extents, sorted descending (m)."""
        return self._obb()[0]

    @property
    def volume(self) -> float:
        """Oriented-box volume (m^3); 0 with 4 points or fewer."""
        return self._obb()[1]

    @property
    def shape(self) -> NDArray[np.float64]:
        """(linearity, planarity, scattering) from PCA."""
        if "shape" not in self._cache:
            self._cache["shape"] = np.array(pca_shape_features(self.points))
        return self._cache["shape"]

    def voxels(self, voxel: float) -> NDArray[np.int64]:
        """Sorted packed voxel keys at resolution ``voxel`` (cached)."""
        key = ("vox", voxel)
        if key not in self._cache:
            self._cache[key] = voxel_set(self.points, voxel)
        return self._cache[key]

    # ---- evaluation truth ----------------------------------------------------------
    @property
    def majority_id(self) -> int:
        """True object id contributing most points (-1 if none/background)."""
        if not self.truth_counts:
            return -1
        return int(max(sorted(self.truth_counts), key=lambda k: self.truth_counts[k]))

    @property
    def purity(self) -> float:
        """Fraction of observed points from the majority object (0 if none)."""
        total = sum(self.truth_counts.values())
        return self.truth_counts[self.majority_id] / total if total else 0.0
