"""Ground truth of a generated world: every object, and the terrain.

This is the contract between the world generator and every later stage. Nothing in
here is given to a mapping or alignment algorithm; it is for simulation and evaluation.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray


@dataclass
class ObjectTruth:
    """One object instance.

    Attributes:
        id: object id (0..n-1, dense); also the id rendered in instance masks.
        family: family name, e.g. ``"conifer"``.
        T_world_obj: 4x4 pose of the object frame (origin at its base centre, z up).
        extents: (3,) oriented-bounding-box extents in metres, sorted descending.
        volume: oriented-bounding-box volume in m^3.
        centroid: (3,) world-frame centroid of the object's mesh volume/vertices.
        geom_ids: MuJoCo geom ids of this object in the compiled model.
        mesh_names: names of the mesh assets of this object (one per geom part).
        obb_T_world: 4x4 pose of the oriented bounding box (centre and axes).
        obb_extents: (3,) extents along ``obb_T_world``'s axes (same order as its columns).
        radius: footprint radius (m) used for spacing.
    """

    id: int
    family: str
    T_world_obj: NDArray[np.float64]
    extents: NDArray[np.float64]
    volume: float
    centroid: NDArray[np.float64]
    geom_ids: list[int]
    mesh_names: list[str]
    obb_T_world: NDArray[np.float64]
    obb_extents: NDArray[np.float64]
    radius: float


def _rounded(a: NDArray[np.float64] | list[float], decimals: int = 6) -> list[Any]:
    rounded: list[Any] = np.round(np.asarray(a, dtype=np.float64), decimals).tolist()
    return rounded


@dataclass(frozen=True)
class ObjectTruthRow:
    """An ``ObjectTruth`` as ``truth.json`` holds it (lists, rounded to 1e-6 so the bytes are stable)."""

    id: int
    family: str
    T_world_obj: list[list[float]]
    extents: list[float]
    volume: float
    centroid: list[float]
    geom_ids: list[int]
    mesh_names: list[str]
    obb_T_world: list[list[float]]
    obb_extents: list[float]
    radius: float

    @classmethod
    def of(cls, o: ObjectTruth) -> ObjectTruthRow:
        """The row of ``o``."""
        return cls(
            int(o.id),
            o.family,
            _rounded(o.T_world_obj),
            _rounded(o.extents),
            round(float(o.volume), 6),
            _rounded(o.centroid),
            [int(g) for g in o.geom_ids],
            list(o.mesh_names),
            _rounded(o.obb_T_world),
            _rounded(o.obb_extents),
            round(float(o.radius), 6),
        )

    def truth(self) -> ObjectTruth:
        """Inverse of ``of``."""
        a = lambda v: np.asarray(v, dtype=np.float64)  # noqa: E731
        return ObjectTruth(
            self.id,
            self.family,
            a(self.T_world_obj),
            a(self.extents),
            float(self.volume),
            a(self.centroid),
            list(self.geom_ids),
            list(self.mesh_names),
            a(self.obb_T_world),
            a(self.obb_extents),
            float(self.radius),
        )


@dataclass(frozen=True)
class SunMeta:
    """The sun a world was lit by (degrees)."""

    azimuth_deg: float
    elevation_deg: float


@dataclass(frozen=True)
class WorldMeta:
    """How a world was made: its spec's name, seed, terrain base and elevation, effective knobs
    (class diversity, size variation, layout regularity), objects placed and requested per
    family, and its sun."""

    name: str
    seed: int
    base_z: float
    elevation: float
    knobs: tuple[float, float, float]
    placed_requested: dict[str, tuple[int, int]]
    sun: SunMeta


@dataclass
class Terrain:
    """A regular heightfield over [-size_x/2, size_x/2] x [-size_y/2, size_y/2].

    ``heights[i, j]`` is the terrain height (m) at row i (y) and column j (x), with
    row 0 at y = -size_y/2 and column 0 at x = -size_x/2 (MuJoCo's hfield layout).
    """

    size_x: float
    size_y: float
    heights: NDArray[np.float64]

    @property
    def shape(self) -> tuple[int, int]:
        rows, cols = self.heights.shape
        return rows, cols

    def height_at(self, x: NDArray[np.float64] | float, y: NDArray[np.float64] | float) -> NDArray[np.float64]:
        """Bilinear terrain height at world (x, y); points outside are clamped to the edge."""
        rows, cols = self.heights.shape
        fx = (np.asarray(x, dtype=np.float64) + self.size_x / 2) / self.size_x * (cols - 1)
        fy = (np.asarray(y, dtype=np.float64) + self.size_y / 2) / self.size_y * (rows - 1)
        fx = np.clip(fx, 0, cols - 1 - 1e-9)
        fy = np.clip(fy, 0, rows - 1 - 1e-9)
        j0, i0 = np.floor(fx).astype(int), np.floor(fy).astype(int)
        ax, ay = fx - j0, fy - i0
        h = self.heights
        return (
            h[i0, j0] * (1 - ax) * (1 - ay)
            + h[i0, j0 + 1] * ax * (1 - ay)
            + h[i0 + 1, j0] * (1 - ax) * ay
            + h[i0 + 1, j0 + 1] * ax * ay
        )

    def normal_at(self, x: float, y: float, step: float | None = None) -> NDArray[np.float64]:
        """Unit terrain normal at (x, y) from central differences."""
        rows, cols = self.heights.shape
        d = step or max(self.size_x / (cols - 1), self.size_y / (rows - 1))
        dzdx = (self.height_at(x + d, y) - self.height_at(x - d, y)) / (2 * d)
        dzdy = (self.height_at(x, y + d) - self.height_at(x, y - d)) / (2 * d)
        n = np.array([-float(dzdx), -float(dzdy), 1.0])
        return n / np.linalg.norm(n)

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        """Whether (x, y) lies inside the terrain with ``margin`` to spare."""
        return abs(x) <= self.size_x / 2 - margin and abs(y) <= self.size_y / 2 - margin


@dataclass
class WorldTruth:
    """All objects and the terrain of a world, plus free corridors (roads) if any."""

    objects: list[ObjectTruth]
    terrain: Terrain
    roads: list[NDArray[np.float64]] = field(default_factory=list)  # each (K, 2) polyline
    meta: WorldMeta | None = None

    def families(self) -> list[str]:
        """Distinct families present, sorted."""
        return sorted({o.family for o in self.objects})

    def centroids(self) -> NDArray[np.float64]:
        """(N, 3) object centroids, ordered by id."""
        if not self.objects:
            return np.zeros((0, 3))
        return np.stack([o.centroid for o in self.objects])

    def geom_to_object(self, ngeom: int) -> NDArray[np.int32]:
        """Lookup table (ngeom,) from MuJoCo geom id to object id (-1 = background)."""
        lut = np.full(ngeom, -1, dtype=np.int32)
        for o in self.objects:
            lut[o.geom_ids] = o.id
        return lut
