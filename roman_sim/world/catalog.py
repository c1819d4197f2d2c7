"""Shared mesh assets of a world: a few shape variants x scale levels per family.

Instances share assets (one MuJoCo mesh per part), so a 1000-object world compiles a few
hundred small meshes at most. Truth is exact: each asset's meshes are stored with the
scale actually used.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import trimesh
from numpy.typing import NDArray

from roman_sim.core.seeding import child_rng
from roman_sim.world.assets import FAMILIES, Part, concat_meshes
from roman_sim.world.spec import FamilySpec


@dataclass(frozen=True)
class Asset:
    """One (family, variant, scale level): its parts and precomputed shape truth."""

    key: str  # e.g. "conifer_v1_s2"
    family: str
    parts: tuple[Part, ...]
    radius: float  # horizontal circumscribed radius about the object origin
    obb_T_local: NDArray[np.float64]  # 4x4 oriented box pose in the object frame
    obb_extents: NDArray[np.float64]  # (3,) along obb_T_local's axes
    centroid_local: NDArray[np.float64]  # (3,)

    def mesh_name(self, part: Part) -> str:
        """MuJoCo mesh asset name of ``part``."""
        return f"{self.key}_{part.name}"

    def combined(self) -> trimesh.Trimesh:
        """All parts as one mesh in the object frame."""
        return concat_meshes(p.mesh for p in self.parts)


@dataclass(frozen=True)
class _Shape:
    """Scale-1 shape truth of one variant (all of it scales linearly)."""

    radius: float
    obb_T: NDArray[np.float64]
    obb_extents: NDArray[np.float64]
    centroid: NDArray[np.float64]


def _shape(parts: list[Part]) -> _Shape:
    """Gravity-aligned oriented box (2D box in xy, z range), radius and volume centroid."""
    mesh = concat_meshes(p.mesh for p in parts)
    v = mesh.vertices
    T2, ext2 = trimesh.bounds.oriented_bounds_2D(v[:, :2])
    T_inv = np.linalg.inv(T2)  # box frame -> object frame (2D)
    obb_T = np.eye(4)
    obb_T[:2, :2], obb_T[:2, 3] = T_inv[:2, :2], T_inv[:2, 2]
    zlo, zhi = v[:, 2].min(), v[:, 2].max()
    obb_T[2, 3] = (zlo + zhi) / 2
    vol, com = _volume_centroid(mesh)
    return _Shape(
        radius=float(np.hypot(v[:, 0], v[:, 1]).max()),
        obb_T=obb_T,
        obb_extents=np.array([ext2[0], ext2[1], zhi - zlo], dtype=np.float64),
        centroid=com if vol > 0 else v.mean(axis=0),
    )


def _volume_centroid(mesh: trimesh.Trimesh) -> tuple[float, NDArray[np.float64]]:
    """Signed volume and centroid from the triangles (closed parts add up; overlaps count twice)."""
    tri = mesh.triangles
    cross = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2]))
    vol = cross.sum() / 6.0
    if vol <= 1e-12:
        return 0.0, np.zeros(3)
    return float(vol), (cross[:, None] * tri.sum(axis=1)).sum(axis=0) / (24.0 * vol)


def _scaled(key: str, family: str, parts: list[Part], shape: _Shape, s: float) -> Asset:
    obb_T = shape.obb_T.copy()
    obb_T[:3, 3] *= s
    return Asset(
        key=key,
        family=family,
        parts=tuple(replace(p, mesh=trimesh.Trimesh(p.mesh.vertices * s, p.mesh.faces, process=False)) for p in parts),
        radius=shape.radius * s,
        obb_T_local=obb_T,
        obb_extents=shape.obb_extents * s,
        centroid_local=shape.centroid * s,
    )


def scale_levels(fam: FamilySpec, size_variation: float) -> NDArray[np.float64]:
    """Scale levels of a family: 3 levels spanning ``size_variation`` of its range, or 1."""
    lo, hi = fam.scale
    mid, half = (lo + hi) / 2, size_variation * (hi - lo) / 2
    if half <= 0:
        return np.array([mid])
    return mid + half * np.array([-1.0, 0.0, 1.0])


def n_variants(fam: FamilySpec, size_variation: float) -> int:
    """Shape variants used at this ``size_variation`` (1 at zero)."""
    return 1 + round(size_variation * (fam.variants - 1))


def variant_parts(seed: int, family: str, variant: int) -> list[Part]:
    """The scale-1 parts of shape variant ``variant`` of ``family`` (seeded per family and variant)."""
    return FAMILIES.get(family)(child_rng(seed, "world", "asset", family, variant))


def family_assets(seed: int, fam: FamilySpec, size_variation: float) -> list[Asset]:
    """Every asset of ``fam`` (variants x scale levels), seeded per family."""
    assets = []
    for v in range(n_variants(fam, size_variation)):
        base = variant_parts(seed, fam.name, v)
        shape = _shape(base)
        for b, s in enumerate(scale_levels(fam, size_variation)):
            assets.append(_scaled(f"{fam.name}_v{v}_s{b}", fam.name, base, shape, float(s)))
    return assets
