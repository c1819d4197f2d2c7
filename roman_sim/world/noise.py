"""Periodic noise for procedural textures: Gaussian-filtered white noise, drawn straight in the
Fourier domain (the transform of white Gaussian noise is white Gaussian noise) at the
frequencies the filter keeps, and brought back with one real inverse FFT (scipy, float32).

Written here because periodic (tileable) noise is what the textures need and the usual noise
libraries do not make it.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np
import scipy.fft
from numpy.typing import NDArray

Batch = NDArray[np.floating]  # (N, n, n): one float32 image per stream of a batch


class NoiseBatch:
    """White and periodic Gaussian noise for a batch of ``len(rngs)`` square images of side ``n``
    pixels, ``tile`` pixels per texture tile (``n`` by default; patterns scale with the tile).

    Image ``i`` draws only from ``rngs[i]``, so it is the same whatever else is in the batch.
    """

    def __init__(self, rngs: Sequence[np.random.Generator], n: int, tile: int | None = None) -> None:
        self.rngs, self.n = list(rngs), int(n)
        self.tile = self.n if tile is None else int(tile)
        if self.tile <= 0 or self.n % self.tile:
            raise ValueError(f"NoiseBatch: the side {self.n} px must hold whole tiles of {self.tile} px")

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
        n, su, sv = self.n, float(sigma_u), float(sigma_u if sigma_v is None else sigma_v)
        rows, cols = _band(n, sv), _cutoff(n, su) + 1
        fv, fu = np.fft.fftfreq(n)[rows], np.fft.rfftfreq(n)[:cols]
        gain = np.exp(-2.0 * np.pi**2 * ((fv[:, None] * sv) ** 2 + (fu[None, :] * su) ** 2)).astype(np.float32)
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


#: The low-pass is cut where its gain falls below 1e-4: |f| < sqrt(ln(1e4) / (2 pi^2)) / sigma.
_CUT = float(np.sqrt(np.log(1e4) / (2.0 * np.pi**2)))


def _cutoff(n: int, sigma: float) -> int:
    """Highest FFT bin (cycles per image) a low-pass of ``sigma`` px keeps."""
    return min(n // 2, int(np.ceil(_CUT * n / max(sigma, 1e-9))))


@lru_cache(maxsize=128)
def _band(n: int, sigma: float) -> NDArray[np.int64]:
    """FFT bins (indices into ``np.fft.fftfreq(n)``) a low-pass of ``sigma`` px keeps, in bin order."""
    return np.flatnonzero(np.abs(np.fft.fftfreq(n)) * n <= _cutoff(n, sigma))
