"""Procedural surface textures (bark, foliage, rock, wood, paint, metal, straw, tiles) and their
mapping onto object meshes.

Each texture is a square grey image, periodic in both directions so it tiles without seams,
with its streaks or grain along the image columns (texture ``v``). Its brightness averages
``TEXTURE_MEAN``; the geom colour multiplies it, so the texture gives the pattern and the
instance its colour. Every object part gets its own realisation (``texture_images`` draws a
batch, one random stream per texture): no two instances show the same patch. The noise is
Gaussian-filtered white noise in the Fourier domain, written here because periodic (tileable)
noise is what the textures need and the usual noise libraries do not make it; a batch is
filtered with one real FFT (scipy), in float32.

Meshes get texture coordinates by box projection, in metres divided by the surface's tile
size, so a texel covers the same area on every object scale. trimesh unwraps meshes only
into atlas charts (through xatlas), which breaks both tiling and the metric scale.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.fft
import trimesh
from numpy.typing import NDArray

from roman_sim.core.registry import Registry
from roman_sim.world.appearance import Variation

TEXTURE_MEAN = 0.6
#: Texture deviations from the mean are scaled by this much. Measured on rendered views of two
#: instances of one shape at the same relative pose (320 x 240, ORB at Kimera-Multi's settings):
#: at 1 the pattern is weaker than the shading of the shape, so coarse ORB features of the shape
#: verify between instances; at 2 (with the mean at 0.6 so that bright texels do not clip) such
#: cross-instance verifications fell by half while views of one instance 2 m apart verified more often.
TEXTURE_CONTRAST = 2.0
Batch = NDArray[np.floating]  # (N, n, n): one image per texture of a batch (float32)


class NoiseBatch:
    """White and periodic Gaussian noise for a batch of ``len(rngs)`` square textures of side ``n``.

    Texture ``i`` draws only from ``rngs[i]``, so it is the same whatever else is in the batch.
    """

    def __init__(self, rngs: Sequence[np.random.Generator], n: int) -> None:
        self.rngs, self.n = list(rngs), int(n)

    def white(self, shape: tuple[int, ...] | None = None) -> Batch:
        """(N, *shape) standard normal draws (``shape`` defaults to (n, n))."""
        s = (self.n, self.n) if shape is None else shape
        return np.stack([r.standard_normal(s, dtype=np.float32) for r in self.rngs])

    def uniform(self, shape: tuple[int, ...]) -> Batch:
        """(N, *shape) draws uniform in [0, 1)."""
        return np.stack([r.random(shape, dtype=np.float32) for r in self.rngs])

    def noise(self, sigma_u: float, sigma_v: float | None = None) -> Batch:
        """(N, n, n) periodic Gaussian noise, zero mean, unit std; feature sizes in pixels (u: across rows).

        White noise is drawn straight in the Fourier domain (the transform of white Gaussian
        noise is white Gaussian noise), only at the frequencies the low-pass keeps.
        """
        n, sv = self.n, float(sigma_u if sigma_v is None else sigma_v)
        rows, cols = _band(n, sv), _cutoff(n, float(sigma_u)) + 1
        gain = _gain(n, float(sigma_u), sv)[np.ix_(rows, np.arange(cols))]
        draw = self.white((len(rows), cols, 2))
        spec = np.zeros((len(self.rngs), n, n // 2 + 1), dtype=np.complex64)
        spec[:, rows, :cols] = (draw[..., 0] + 1j * draw[..., 1]) * gain
        out = scipy.fft.irfft2(spec, s=(n, n), axes=(-2, -1))
        out -= out.mean(axis=(-2, -1), keepdims=True)
        return out / np.maximum(out.std(axis=(-2, -1), keepdims=True), np.float32(1e-12))

    def fbm(self, sigmas: tuple[float, ...], gain: float = 0.55) -> Batch:
        """Octaves of ``noise`` (largest feature first, each ``gain`` times the last), unit std."""
        out = sum(gain**k * self.noise(s) for k, s in enumerate(sorted(sigmas, reverse=True)))
        assert isinstance(out, np.ndarray)
        return out / out.std(axis=(-2, -1), keepdims=True)


@lru_cache(maxsize=128)
def _gain(n: int, sigma_u: float, sigma_v: float) -> NDArray[np.float32]:
    """Gaussian low-pass in the real-FFT domain: sigma_v along rows (v), sigma_u along columns (u)."""
    fv, fu = np.fft.fftfreq(n), np.fft.rfftfreq(n)
    return np.exp(-2.0 * np.pi**2 * ((fv[:, None] * sigma_v) ** 2 + (fu[None, :] * sigma_u) ** 2)).astype(np.float32)


#: The low-pass is cut where its gain falls below 1e-4: |f| < sqrt(ln(1e4) / (2 pi^2)) / sigma.
_CUT = float(np.sqrt(np.log(1e4) / (2.0 * np.pi**2)))


def _cutoff(n: int, sigma: float) -> int:
    """Highest FFT bin (cycles per image) a low-pass of ``sigma`` px keeps."""
    return min(n // 2, int(np.ceil(_CUT * n / max(sigma, 1e-9))))


@lru_cache(maxsize=128)
def _band(n: int, sigma: float) -> NDArray[np.int64]:
    """FFT bins (indices into ``np.fft.fftfreq(n)``) a low-pass of ``sigma`` px keeps, in bin order."""
    return np.flatnonzero(np.abs(np.fft.fftfreq(n)) * n <= _cutoff(n, sigma))


TextureFn = Callable[[NoiseBatch], Batch]


@dataclass(frozen=True)
class Surface:
    """A surface kind: its texture, texture tile size, colour range and shine."""

    texture: TextureFn  # NoiseBatch -> (N, n, n) brightness patterns (any scale; normalised later)
    tile_m: float  # metres covered by one copy of the texture
    variation: Variation  # per-instance colour range at instance_variation = 1
    specular: float = 0.0
    shininess: float = 0.2


SURFACES: Registry[Surface] = Registry("surface kind")


def _bark(nb: NoiseBatch) -> Batch:
    n = nb.n
    streaks = nb.noise(0.012 * n, 0.12 * n)
    cracks = np.clip(-nb.noise(0.008 * n, 0.2 * n) - 0.8, 0.0, None)
    return 1.0 + 0.16 * streaks + 0.05 * nb.noise(1.0) - 0.5 * cracks


def _foliage(nb: NoiseBatch) -> Batch:
    n = nb.n
    clumps = nb.fbm((0.1 * n, 0.03 * n))
    leaves = np.tanh(2.5 * nb.noise(0.008 * n + 0.5))
    return 1.0 + 0.12 * clumps + 0.14 * leaves - 0.2 * (clumps < -1.0)


def _rock(nb: NoiseBatch) -> Batch:
    n = nb.n
    veins = np.exp(-np.abs(nb.noise(0.04 * n)) * 10.0)
    return 1.0 + 0.2 * nb.fbm((0.12 * n, 0.04 * n, 0.012 * n)) + 0.06 * nb.noise(0.7) - 0.35 * veins


def _wood(nb: NoiseBatch) -> Batch:
    n = nb.n
    u = (np.arange(n, dtype=np.float32) / n)[None, None, :]
    rings = np.sin(2 * np.pi * (12 * u + 0.6 * nb.noise(0.05 * n, 0.3 * n)))
    return 1.0 + 0.1 * rings + 0.06 * nb.noise(0.006 * n, 0.1 * n) + 0.03 * nb.noise(0.7)


def _paint(nb: NoiseBatch) -> Batch:
    n = nb.n
    dirt = np.clip(nb.noise(0.05 * n) - 0.8, 0.0, None)
    return 1.0 + 0.04 * nb.noise(0.8) + 0.05 * nb.noise(0.02 * n) - 0.25 * dirt


def _metal(nb: NoiseBatch) -> Batch:
    n = nb.n
    return 1.0 + 0.07 * nb.noise(0.6, 0.15 * n) + 0.04 * nb.noise(0.1 * n)


def _straw(nb: NoiseBatch) -> Batch:
    n = nb.n
    return 1.0 + 0.16 * np.tanh(2.0 * nb.noise(0.005 * n + 0.4, 0.1 * n)) + 0.05 * nb.noise(0.05 * n)


def _tiles(nb: NoiseBatch, rows: int = 8) -> Batch:
    """Overlapping roof tiles: bands along u, a shade per tile, dark joints, each band of tiles
    shifted along v by its own draw (so the joints of two roofs do not line up)."""
    n = nb.n
    r = np.arange(n)[:, None] * rows / n
    ri = np.floor(r).astype(int) % rows
    c = np.arange(n)[None, None, :] * 2 * rows / n + nb.uniform((rows,))[:, ri]  # (N, n, n)
    ci = np.floor(c).astype(int) % (2 * rows)
    shade = np.take_along_axis(nb.white((rows, 2 * rows))[:, ri[:, 0], :], ci, axis=2)
    joint = (r % 1.0 > 0.9) | (c % 1.0 > 0.93)
    return 1.0 + 0.06 * shade + 0.08 * (r % 1.0) + 0.03 * nb.noise(0.8) - 0.3 * joint


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

#: Textures filtered together at most (bounds the float32 work arrays to ~ BATCH * n^2 * 16 B).
BATCH = 64


def texture_images(kind: str, rngs: Sequence[np.random.Generator], n: int) -> NDArray[np.uint8]:
    """(N, n, n, 3) uint8 grey textures of surface ``kind``, one per stream, brightness averaging ``TEXTURE_MEAN``."""
    surface = SURFACES.get(kind)
    out = np.empty((len(rngs), n, n, 3), dtype=np.uint8)
    for lo in range(0, len(rngs), BATCH):
        raw = surface.texture(NoiseBatch(rngs[lo : lo + BATCH], n))
        rel = raw / raw.mean(axis=(-2, -1), keepdims=True)
        lum = np.clip(TEXTURE_MEAN * (1.0 + TEXTURE_CONTRAST * (rel - 1.0)), 0.0, 1.0)
        out[lo : lo + BATCH] = np.round(lum * 255.0).astype(np.uint8)[..., None]
    return out


def texture_image(kind: str, rng: np.random.Generator, n: int) -> NDArray[np.uint8]:
    """(n, n, 3) uint8 grey texture of surface ``kind`` (``texture_images`` of one stream)."""
    return texture_images(kind, [rng], n)[0]


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
