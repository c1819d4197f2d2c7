"""Procedural surface textures (bark, foliage, rock, wood, paint, metal, straw, tiles) and their
mapping onto object meshes.

Each texture is a square grey image, periodic in both directions so it tiles without seams,
with its streaks or grain along the image columns (texture ``v``). Its brightness averages
``TEXTURE_MEAN``; the geom colour multiplies it, so instances of one mesh share one texture
and still differ in colour. The noise is Gaussian-filtered white noise in the Fourier
domain, written here because periodic (tileable) noise is what the textures need and the
usual noise libraries do not make it.

Meshes get texture coordinates by box projection, in metres divided by the surface's tile
size, so a texel covers the same area on every object scale. trimesh unwraps meshes only
into atlas charts (through xatlas), which breaks both tiling and the metric scale.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray

from roman_sim.core.registry import Registry
from roman_sim.world.appearance import Variation

TEXTURE_MEAN = 0.78
TextureFn = Callable[[np.random.Generator, int], NDArray[np.float64]]


@dataclass(frozen=True)
class Surface:
    """A surface kind: its texture, texture tile size, colour range and shine."""

    texture: TextureFn  # (rng, n) -> (n, n) brightness pattern (any scale; normalised later)
    tile_m: float  # metres covered by one copy of the texture
    variation: Variation  # per-instance colour range at instance_variation = 1
    specular: float = 0.0
    shininess: float = 0.2


SURFACES: Registry[Surface] = Registry("surface kind")


def noise(rng: np.random.Generator, n: int, sigma_u: float, sigma_v: float | None = None) -> NDArray[np.float64]:
    """(n, n) periodic Gaussian noise, zero mean, unit std; feature sizes in pixels (u: across rows)."""
    sv = sigma_u if sigma_v is None else sigma_v
    f = np.fft.fftfreq(n)
    gain = np.exp(-2.0 * np.pi**2 * ((f[:, None] * sv) ** 2 + (f[None, :] * sigma_u) ** 2))
    out = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((n, n))) * gain))
    return (out - out.mean()) / max(float(out.std()), 1e-12)


def _fbm(rng: np.random.Generator, n: int, sigmas: tuple[float, ...], gain: float = 0.55) -> NDArray[np.float64]:
    out = np.zeros((n, n))
    for k, s in enumerate(sorted(sigmas, reverse=True)):
        out += gain**k * noise(rng, n, s)
    return out / float(np.std(out))


def _bark(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    streaks = noise(rng, n, 0.012 * n, 0.12 * n)
    cracks = np.clip(-noise(rng, n, 0.008 * n, 0.2 * n) - 0.8, 0.0, None)
    return 1.0 + 0.16 * streaks + 0.05 * noise(rng, n, 1.0) - 0.5 * cracks


def _foliage(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    clumps = _fbm(rng, n, (0.1 * n, 0.03 * n))
    leaves = np.tanh(2.5 * noise(rng, n, 0.008 * n + 0.5))
    return 1.0 + 0.12 * clumps + 0.14 * leaves - 0.2 * (clumps < -1.0)


def _rock(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    veins = np.exp(-np.abs(noise(rng, n, 0.04 * n)) * 10.0)
    return 1.0 + 0.2 * _fbm(rng, n, (0.12 * n, 0.04 * n, 0.012 * n)) + 0.06 * noise(rng, n, 0.7) - 0.35 * veins


def _wood(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    u = np.arange(n)[None, :] / n
    rings = np.sin(2 * np.pi * (12 * u + 0.6 * noise(rng, n, 0.05 * n, 0.3 * n)))
    return 1.0 + 0.1 * rings + 0.06 * noise(rng, n, 0.006 * n, 0.1 * n) + 0.03 * noise(rng, n, 0.7)


def _paint(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    dirt = np.clip(noise(rng, n, 0.08 * n) - 1.0, 0.0, None)
    return 1.0 + 0.03 * noise(rng, n, 0.8) + 0.02 * noise(rng, n, 0.03 * n) - 0.1 * dirt


def _metal(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    return 1.0 + 0.07 * noise(rng, n, 0.6, 0.15 * n) + 0.04 * noise(rng, n, 0.1 * n)


def _straw(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    return 1.0 + 0.16 * np.tanh(2.0 * noise(rng, n, 0.005 * n + 0.4, 0.1 * n)) + 0.05 * noise(rng, n, 0.05 * n)


def _tiles(rng: np.random.Generator, n: int, rows: int = 8) -> NDArray[np.float64]:
    """Overlapping roof tiles: bands along u, a shade per tile, dark joints."""
    r = np.arange(n)[:, None] * rows / n
    c = np.arange(n)[None, :] * 2 * rows / n + 0.5 * (np.floor(r) % 2)
    shade = rng.normal(0.0, 1.0, (rows, 2 * rows))[np.floor(r).astype(int) % rows, np.floor(c).astype(int) % (2 * rows)]
    joint = (r % 1.0 > 0.9) | (c % 1.0 > 0.93)
    return 1.0 + 0.06 * shade + 0.08 * (r % 1.0) + 0.03 * noise(rng, n, 0.8) - 0.3 * joint


for _name, _surface in {
    "bark": Surface(_bark, 1.2, Variation(8.0, 0.10, 0.25)),
    "foliage": Surface(_foliage, 1.5, Variation(15.0, 0.15, 0.25)),
    "rock": Surface(_rock, 1.5, Variation(12.0, 0.05, 0.25)),
    "wood": Surface(_wood, 1.0, Variation(6.0, 0.10, 0.20)),
    "paint": Surface(_paint, 2.0, Variation(10.0, 0.10, 0.15), specular=0.3, shininess=0.4),
    "metal": Surface(_metal, 1.0, Variation(5.0, 0.03, 0.20), specular=0.5, shininess=0.6),
    "straw": Surface(_straw, 0.8, Variation(6.0, 0.10, 0.15)),
    "tiles": Surface(_tiles, 2.5, Variation(10.0, 0.10, 0.20), specular=0.1),
}.items():
    SURFACES.register(_name, _surface)


def texture_image(kind: str, rng: np.random.Generator, n: int) -> NDArray[np.uint8]:
    """(n, n, 3) uint8 grey texture of surface ``kind``, brightness averaging ``TEXTURE_MEAN``."""
    raw = SURFACES.get(kind).texture(rng, n)
    lum = np.clip(raw * (TEXTURE_MEAN / float(raw.mean())), 0.0, 1.0)
    grey = np.round(lum * 255.0).astype(np.uint8)
    return np.repeat(grey[..., None], 3, axis=2)


# box projection: for a face whose normal is mostly along axis a, (u, v) read these axes,
# v along the grain axis g unless the face looks along g (then the other two axes)
_OTHER = {frozenset((0, 1)): 2, frozenset((0, 2)): 1, frozenset((1, 2)): 0}


def _uv_axes(grain: int) -> NDArray[np.int64]:
    table = np.zeros((3, 2), dtype=np.int64)
    for a in range(3):
        table[a] = sorted({0, 1, 2} - {a}) if a == grain else (_OTHER[frozenset((a, grain))], grain)
    return table


def box_uv(mesh: trimesh.Trimesh, tile_m: float, grain_axis: int = 2) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
    """Per-corner texture coordinates by box projection.

    Returns:
        texcoord (3F, 2) float32 in texture tiles (metres / ``tile_m``) and the face texcoord
        indices (3F,) int32 (corner ``k`` of face ``f`` uses row ``3 f + k``).
    """
    if not 0 <= grain_axis <= 2 or tile_m <= 0:
        raise ValueError(f"box_uv: grain_axis must be 0, 1 or 2 and tile_m > 0 (got {grain_axis}, {tile_m})")
    tri = np.asarray(mesh.triangles, dtype=np.float64)  # (F, 3, 3)
    axes = _uv_axes(grain_axis)[np.argmax(np.abs(mesh.face_normals), axis=1)]  # (F, 2)
    uv = np.take_along_axis(tri, axes[:, None, :], axis=2) / tile_m  # (F, 3, 2)
    return uv.reshape(-1, 2).astype(np.float32), np.arange(3 * len(tri), dtype=np.int32)
