"""Fractal-noise terrain: value noise summed over octaves, sampled on the hfield grid.

The heights are quantised exactly as MuJoCo stores them (float32 fractions of the
elevation range above a base height), so ``Terrain.height_at`` agrees with the compiled
hfield at the grid nodes.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import map_coordinates

from roman_sim.world.spec import TerrainSpec
from roman_sim.world.truth import Terrain

MIN_ELEVATION_M = 1e-3  # MuJoCo needs a positive hfield elevation even for flat ground


def grid_shape(extent_m: tuple[float, float], resolution_m: float) -> tuple[int, int]:
    """(rows, cols) of the hfield for an extent and cell size (at least 2 x 2)."""
    cols = max(2, int(round(extent_m[0] / resolution_m)) + 1)
    rows = max(2, int(round(extent_m[1] / resolution_m)) + 1)
    return rows, cols


def _octave(
    rng: np.random.Generator, rows: int, cols: int, extent_m: tuple[float, float], wavelength: float
) -> NDArray[np.float64]:
    """Smooth value noise in [-1, 1] with lattice pitch ``wavelength`` metres."""
    nx = int(np.ceil(extent_m[0] / wavelength)) + 2
    ny = int(np.ceil(extent_m[1] / wavelength)) + 2
    lattice = rng.uniform(-1.0, 1.0, (ny, nx))
    fy = np.linspace(0.0, extent_m[1] / wavelength, rows)
    fx = np.linspace(0.0, extent_m[0] / wavelength, cols)
    gy, gx = np.meshgrid(fy, fx, indexing="ij")
    return map_coordinates(lattice, [gy, gx], order=3, mode="nearest")


def make_terrain(
    spec: TerrainSpec, extent_m: tuple[float, float], rng: np.random.Generator
) -> tuple[Terrain, float, float]:
    """Generate the terrain.

    Returns:
        (terrain, base_z, elevation): ``terrain.heights == base_z + elevation * data`` where
        ``data`` (float32 in [0, 1]) is what the hfield stores.
    """
    rows, cols = grid_shape(extent_m, spec.resolution_m)
    h = np.zeros((rows, cols))
    if spec.amplitude_m > 0:
        amp, wl = 1.0, spec.feature_size_m
        for _ in range(spec.octaves):
            h += amp * _octave(rng, rows, cols, extent_m, wl)
            amp *= spec.roughness
            wl = max(wl / 2.0, spec.resolution_m * 2)
        peak = np.abs(h).max()
        h *= spec.amplitude_m / peak if peak > 0 else 0.0
    base_z = float(h.min())
    elevation = max(float(h.max()) - base_z, MIN_ELEVATION_M)
    data = ((h - base_z) / elevation).astype(np.float32)
    heights = base_z + elevation * data.astype(np.float64)
    return Terrain(size_x=float(extent_m[0]), size_y=float(extent_m[1]), heights=heights), base_z, elevation


def hfield_data(terrain: Terrain, base_z: float, elevation: float) -> NDArray[np.float32]:
    """The normalised hfield data (rows, cols) for ``terrain`` (inverse of ``make_terrain``)."""
    return ((terrain.heights - base_z) / elevation).astype(np.float32)


def footprint_min_height(terrain: Terrain, x: float, y: float, radius: float, n: int = 8) -> float:
    """Lowest terrain height over the centre and a ring of ``n`` points at ``radius``."""
    a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    xs = np.concatenate([[x], x + radius * np.cos(a)])
    ys = np.concatenate([[y], y + radius * np.sin(a)])
    return float(np.min(terrain.height_at(xs, ys)))
