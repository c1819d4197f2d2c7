"""Shared mesh assets of a world: a few shape variants x scale levels per family.

Instances share assets (one MuJoCo mesh per part), so a 1000-object world compiles a few
hundred small meshes at most. Truth is exact: each asset's meshes are stored with the
scale actually used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray

from roman_sim.seeding import child_rng
from roman_sim.world.assets import FAMILIES, Part
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
        return trimesh.util.concatenate([p.mesh for p in self.parts])


def _make_asset(key: str, family: str, parts: list[Part]) -> Asset:
    mesh = trimesh.util.concatenate([p.mesh for p in parts])
    v = mesh.vertices
    T_obb, ext = trimesh.bounds.oriented_bounds(mesh)
    centroid = mesh.center_mass if mesh.is_volume else v.mean(axis=0)
    return Asset(
        key=key,
        family=family,
        parts=tuple(parts),
        radius=float(np.hypot(v[:, 0], v[:, 1]).max()),
        obb_T_local=np.linalg.inv(T_obb),
        obb_extents=np.asarray(ext, dtype=np.float64),
        centroid_local=np.asarray(centroid, dtype=np.float64),
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
    return 1 + int(round(size_variation * (fam.variants - 1)))


def family_assets(seed: int, fam: FamilySpec, size_variation: float) -> list[Asset]:
    """Every asset of ``fam`` (variants x scale levels), seeded per family."""
    assets = []
    for v in range(n_variants(fam, size_variation)):
        rng = child_rng(seed, "world", "asset", fam.name, v)
        base = FAMILIES.get(fam.name)(rng)
        for b, s in enumerate(scale_levels(fam, size_variation)):
            parts = [Part(p.name, p.mesh.copy().apply_scale(float(s)), p.rgba) for p in base]
            assets.append(_make_asset(f"{fam.name}_v{v}_s{b}", fam.name, parts))
    return assets
