"""Procedural surface textures (bark, foliage, rock, wood, paint, metal, straw, tiles) and their
mapping onto object meshes.

A texture is a square grey image, periodic in both directions so it tiles without seams,
with its streaks or grain along the image columns (texture ``v``); its patterns are sized
relative to one *tile* (``tile_m`` metres of surface), and an image may hold several tiles
of one realisation. Its brightness averages ``TEXTURE_MEAN``; the geom colour multiplies
it, so the texture gives the pattern and the instance its colour.

Meshes get texture coordinates by box projection, in metres divided by the surface's tile
size, so a texel covers the same area on every object scale. trimesh unwraps meshes only
into atlas charts (through xatlas), which breaks both tiling and the metric scale. Every
instance then looks at its own region of its surface kind's atlas (``instance_uv``: a
seeded offset and a symmetry of the tile grid, on the instance's own copy of the mesh).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray

from roman_sim.core.registry import Registry
from roman_sim.world.appearance import Variation
from roman_sim.world.noise import Batch, NoiseBatch

TEXTURE_MEAN = 0.6
#: Texture deviations from the mean are scaled by this much. Measured on rendered views of two
#: instances of one shape at the same relative pose (320 x 240, ORB at Kimera-Multi's settings):
#: at 1 the pattern is weaker than the shading of the shape, so coarse ORB features of the shape
#: verify between instances; at 2 (with the mean at 0.6 so that bright texels do not clip) such
#: cross-instance verifications fell by half while views of one instance 2 m apart verified more often.
TEXTURE_CONTRAST = 2.0
TextureFn = Callable[[NoiseBatch], Batch]


@dataclass(frozen=True)
class Surface:
    """A surface kind: its texture, texture tile size, colour range, shine and symmetry."""

    texture: TextureFn  # NoiseBatch -> (N, n, n) brightness patterns (any scale; normalised later)
    tile_m: float  # metres covered by one tile of the texture
    variation: Variation  # per-instance colour range at instance_variation = 1
    specular: float = 0.0
    shininess: float = 0.2
    isotropic: bool = False  # no grain or rows: the texture may be turned by 90 degrees


SURFACES: Registry[Surface] = Registry("surface kind")


def _bark(nb: NoiseBatch) -> Batch:
    t = nb.tile
    streaks = nb.noise(0.012 * t, 0.12 * t)
    cracks = np.clip(-nb.noise(0.008 * t, 0.2 * t) - 0.8, 0.0, None)
    return 1.0 + 0.16 * streaks + 0.05 * nb.noise(1.0) - 0.5 * cracks


def _foliage(nb: NoiseBatch) -> Batch:
    t = nb.tile
    clumps = nb.fbm((0.1 * t, 0.03 * t))
    leaves = np.tanh(2.5 * nb.noise(0.008 * t + 0.5))
    return 1.0 + 0.12 * clumps + 0.14 * leaves - 0.2 * (clumps < -1.0)


def _rock(nb: NoiseBatch) -> Batch:
    t = nb.tile
    veins = np.exp(-np.abs(nb.noise(0.04 * t)) * 10.0)
    return 1.0 + 0.2 * nb.fbm((0.12 * t, 0.04 * t, 0.012 * t)) + 0.06 * nb.noise(0.7) - 0.35 * veins


def _wood(nb: NoiseBatch) -> Batch:
    t = nb.tile
    u = (np.arange(nb.n, dtype=np.float32) / t)[None, None, :]
    rings = np.sin(2 * np.pi * (12 * u + 0.6 * nb.noise(0.05 * t, 0.3 * t)))
    return 1.0 + 0.1 * rings + 0.06 * nb.noise(0.006 * t, 0.1 * t) + 0.03 * nb.noise(0.7)


def _paint(nb: NoiseBatch) -> Batch:
    t = nb.tile
    dirt = np.clip(nb.noise(0.05 * t) - 0.8, 0.0, None)
    return 1.0 + 0.04 * nb.noise(0.8) + 0.05 * nb.noise(0.02 * t) - 0.25 * dirt


def _metal(nb: NoiseBatch) -> Batch:
    t = nb.tile
    return 1.0 + 0.07 * nb.noise(0.6, 0.15 * t) + 0.04 * nb.noise(0.1 * t)


def _straw(nb: NoiseBatch) -> Batch:
    t = nb.tile
    return 1.0 + 0.16 * np.tanh(2.0 * nb.noise(0.005 * t + 0.4, 0.1 * t)) + 0.05 * nb.noise(0.05 * t)


def _tiles(nb: NoiseBatch, rows: int = 8) -> Batch:
    """Overlapping roof tiles: ``rows`` bands along u per tile, a shade per roof tile, dark
    joints, each band shifted along v by its own draw (so the joints of two roofs differ)."""
    bands = rows * nb.n // nb.tile
    r = np.arange(nb.n)[:, None] * rows / nb.tile
    ri = np.floor(r).astype(int) % bands
    c = np.arange(nb.n)[None, None, :] * 2 * rows / nb.tile + nb.uniform((bands,))[:, ri]  # (N, n, n)
    ci = np.floor(c).astype(int) % (2 * bands)
    shade = np.take_along_axis(nb.white((bands, 2 * bands))[:, ri[:, 0], :], ci, axis=2)
    joint = (r % 1.0 > 0.9) | (c % 1.0 > 0.93)
    return 1.0 + 0.06 * shade + 0.08 * (r % 1.0) + 0.03 * nb.noise(0.8) - 0.3 * joint


for _name, _surface in {
    "bark": Surface(_bark, 1.2, Variation(8.0, 0.10, 0.25)),
    "foliage": Surface(_foliage, 1.5, Variation(15.0, 0.15, 0.25), isotropic=True),
    "rock": Surface(_rock, 1.5, Variation(12.0, 0.05, 0.25), isotropic=True),
    "wood": Surface(_wood, 1.0, Variation(6.0, 0.10, 0.20)),
    "paint": Surface(_paint, 2.0, Variation(10.0, 0.10, 0.15), specular=0.3, shininess=0.4, isotropic=True),
    "metal": Surface(_metal, 1.0, Variation(5.0, 0.03, 0.20), specular=0.5, shininess=0.6),
    "straw": Surface(_straw, 0.8, Variation(6.0, 0.10, 0.15)),
    "tiles": Surface(_tiles, 2.5, Variation(10.0, 0.10, 0.20), specular=0.1),
}.items():
    SURFACES.register(_name, _surface)


def texture_images(
    kind: str, rngs: Sequence[np.random.Generator], n: int, tile_px: int | None = None
) -> NDArray[np.uint8]:
    """(N, n, n, 3) uint8 grey textures of surface ``kind``, one per stream, ``tile_px`` pixels
    per tile (``n``: one tile), brightness averaging ``TEXTURE_MEAN``."""
    raw = SURFACES.get(kind).texture(NoiseBatch(rngs, n, tile_px))
    rel = raw / raw.mean(axis=(-2, -1), keepdims=True)
    lum = np.clip(TEXTURE_MEAN * (1.0 + TEXTURE_CONTRAST * (rel - 1.0)), 0.0, 1.0)
    return np.repeat(np.round(lum * 255.0).astype(np.uint8)[..., None], 3, axis=-1)


def texture_image(kind: str, rng: np.random.Generator, n: int, tile_px: int | None = None) -> NDArray[np.uint8]:
    """(n, n, 3) uint8 grey texture of surface ``kind`` (``texture_images`` of one stream)."""
    return texture_images(kind, [rng], n, tile_px)[0]


# the symmetries of the square tile grid an instance's texture may be seen through: all 8 for
# isotropic surfaces, the 4 that keep the grain (along v) for the others
_TURNS = np.array([[[1, 0], [0, 1]], [[0, -1], [1, 0]], [[-1, 0], [0, -1]], [[0, 1], [-1, 0]]], dtype=np.float64)
_MIRROR = np.array([[-1.0, 0.0], [0.0, 1.0]])
_SYMMETRIES = np.concatenate([_TURNS, _TURNS @ _MIRROR])
_GRAIN_INDEX = (0, 2, 4, 6)
_GRAIN_KEEPING = _SYMMETRIES[list(_GRAIN_INDEX)]


def instance_uv(uv: NDArray[np.float32], kind: str, atlas_tiles: int, rng: np.random.Generator) -> NDArray[np.float32]:
    """Box-projection ``uv`` (in tiles) moved into an instance's own region of a kind's atlas.

    The atlas is one periodic texture of ``atlas_tiles`` x ``atlas_tiles`` tiles; the instance
    sees it through a symmetry of the tile grid and from an offset uniform over the atlas, both
    drawn from ``rng``. Returns texture coordinates in atlas units (1 = the whole atlas).
    """
    sym, offset = instance_region(kind, atlas_tiles, rng)
    M = _SYMMETRIES[sym]
    return ((np.asarray(uv, np.float64) @ M.T + offset) / atlas_tiles).astype(np.float32)


def instance_region(kind: str, atlas_tiles: int, rng: np.random.Generator) -> tuple[int, NDArray[np.float64]]:
    """An instance's region of a kind's atlas, drawn from ``rng``: the index of its tile-grid
    symmetry (into all 8; a grained kind draws among the 4 that keep the grain) and its offset (2,)
    in tiles, uniform over the atlas."""
    isotropic = SURFACES.get(kind).isotropic
    pick = int(rng.integers(0, len(_SYMMETRIES) if isotropic else len(_GRAIN_KEEPING)))
    offset = rng.uniform(0.0, atlas_tiles, 2)
    return (pick if isotropic else _GRAIN_INDEX[pick]), offset


# box projection: for a face whose normal is mostly along axis a, (u, v) read these axes,
# v along the grain axis g unless the face looks along g (then the other two axes)
_OTHER = {frozenset((0, 1)): 2, frozenset((0, 2)): 1, frozenset((1, 2)): 0}


def _uv_axes(grain: int) -> NDArray[np.int64]:
    table = np.zeros((3, 2), dtype=np.int64)
    for a in range(3):
        table[a] = sorted({0, 1, 2} - {a}) if a == grain else (_OTHER[frozenset((a, grain))], grain)
    return table


#: Offset (tiles) of the texture region of each of the six box-projection directions (+x, -x,
#: +y, -y, +z, -z), ``d * FACE_STEP_TILES`` for direction ``d``. Without it two faces that
#: project along different axes show the same texture where their coordinates agree: the
#: +x wall of a house at y = -2.4 m and its -y wall at x = -2.4 m looked alike, and a robot
#: driving round the house verified the two walls, 7 m apart, as one place. The steps keep
#: the six regions at least 6.5 tiles apart in the default 32-tile atlas (wider than a wall).
FACE_STEP_TILES = (6.5, 4.25)


def box_uv(mesh: trimesh.Trimesh, tile_m: float, grain_axis: int = 2) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
    """Per-corner texture coordinates by box projection, each projection direction in its own
    region of the texture (``FACE_STEP_TILES``).

    Returns:
        texcoord (3F, 2) float32 in texture tiles (metres / ``tile_m``) and the face texcoord
        indices (3F,) int32 (corner ``k`` of face ``f`` uses row ``3 f + k``).
    """
    if not 0 <= grain_axis <= 2 or tile_m <= 0:
        raise ValueError(f"box_uv: grain_axis must be 0, 1 or 2 and tile_m > 0 (got {grain_axis}, {tile_m})")
    tri = np.asarray(mesh.triangles, dtype=np.float64)  # (F, 3, 3)
    normals = np.asarray(mesh.face_normals)
    dominant = np.argmax(np.abs(normals), axis=1)
    axes = _uv_axes(grain_axis)[dominant]  # (F, 2)
    uv = np.take_along_axis(tri, axes[:, None, :], axis=2) / tile_m  # (F, 3, 2)
    direction = 2 * dominant + (np.take_along_axis(normals, dominant[:, None], axis=1)[:, 0] < 0)
    uv += direction[:, None, None] * np.asarray(FACE_STEP_TILES)
    return uv.reshape(-1, 2).astype(np.float32), np.arange(3 * len(tri), dtype=np.int32)
