"""The ground texture: grass with seeded colour noise and the roads painted in, one image
stretched once over the whole hfield (texture row 0 at +y, column 0 at -x)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import distance_transform_edt, zoom

from roman_sim.world.roads import Polyline
from roman_sim.world.truth import Terrain

MAX_TEXTURE_PX = 1024
MIN_PIXEL_M = 0.2
GRASS = np.array([84.0, 115.0, 56.0])
ROAD = np.array([122.0, 108.0, 88.0])


def texture_shape(terrain: Terrain) -> tuple[int, int]:
    """(rows, cols) of the ground texture for ``terrain``."""
    px = max(MIN_PIXEL_M, max(terrain.size_x, terrain.size_y) / MAX_TEXTURE_PX)
    return max(8, int(round(terrain.size_y / px))), max(8, int(round(terrain.size_x / px)))


def _road_distance_px(shape: tuple[int, int], terrain: Terrain, roads: list[Polyline]) -> NDArray[np.float64]:
    """Distance (metres) from every texel to the nearest road centre line."""
    rows, cols = shape
    mx, my = terrain.size_x / cols, terrain.size_y / rows
    centre = np.zeros(shape, dtype=bool)
    for line in roads:
        seg_len = np.linalg.norm(np.diff(line, axis=0), axis=1).sum()
        t = np.linspace(0.0, 1.0, max(2, int(seg_len / (0.5 * min(mx, my))) + 2))
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
        x = np.interp(t * s[-1], s, line[:, 0])
        y = np.interp(t * s[-1], s, line[:, 1])
        c = np.clip(((x + terrain.size_x / 2) / mx).astype(int), 0, cols - 1)
        r = np.clip(((terrain.size_y / 2 - y) / my).astype(int), 0, rows - 1)
        centre[r, c] = True
    if not centre.any():
        return np.full(shape, np.inf)
    return distance_transform_edt(~centre, sampling=(my, mx))


def ground_texture(
    terrain: Terrain, roads: list[Polyline], road_width_m: float, rng: np.random.Generator
) -> NDArray[np.uint8]:
    """(rows, cols, 3) RGB ground image: patchy grass, fine noise and the road surfaces."""
    shape = texture_shape(terrain)
    coarse = rng.normal(0.0, 1.0, (max(2, shape[0] // 32), max(2, shape[1] // 32)))
    patches = zoom(coarse, (shape[0] / coarse.shape[0], shape[1] / coarse.shape[1]), order=1)[: shape[0], : shape[1]]
    fine = rng.normal(0.0, 1.0, shape)
    img = GRASS * (1.0 + 0.12 * patches[..., None]) + 10.0 * fine[..., None]
    if roads and road_width_m > 0:
        dist = _road_distance_px(shape, terrain, roads)
        w = np.clip((road_width_m / 2 - dist) / 0.5 + 0.5, 0.0, 1.0)[..., None]  # 0.5 m soft edge
        img = (1 - w) * img + w * (ROAD + 6.0 * fine[..., None])
    return np.clip(img, 0, 255).astype(np.uint8)
