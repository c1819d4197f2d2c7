"""The ground texture: grass with seeded colour noise and the roads painted in, one image
stretched once over the whole hfield (texture row 0 at +y, column 0 at -x).

Untextured worlds get a coarse image (``plain_texture_shape``: 0.2 m texels or coarser).
Textured worlds get a fine one (``appearance.ground_texel_m``, 2.5 cm by default) with
detail at every scale from one texel to a few metres: gravel and ruts on the roads, tufts
and bare patches in the grass. The image is one realisation over the whole world, so no
stretch of ground repeats another. Why: seen from a robot's camera 0.4 m above it, the
ground fills most of the image within the depth range; as 0.2 m texels of faint noise it
rendered as a smooth smear with almost no ORB features, so keyframes were left with a few
dozen features on one or two objects, and chance matches to them were verified as loop
closures between places 50 m apart (``tests/align/visual/test_ground.py`` has the figures).

The detail is a log-brightness sum of octaves of Gaussian-smoothed white noise, one per
doubling of the feature size from one texel up (equal weight per octave, as in natural
images; roads weigh the fine octaves more than grass). It is made in blocks of rows, each
drawing its own white noise, so the memory beyond the image itself stays small.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import distance_transform_edt, gaussian_filter, zoom

from roman_sim.world.appearance import ground_shape
from roman_sim.world.roads import Polyline
from roman_sim.world.truth import Terrain

MAX_TEXTURE_PX = 1024  # side of the plain (untextured) ground image
MIN_PIXEL_M = 0.2  # texel of the plain ground image
GRASS = np.array([84.0, 115.0, 56.0])
ROAD = np.array([122.0, 108.0, 88.0])
PATCH_M = 6.4  # size of the colour patches of the grass
EDGE_M = 0.5  # width of the soft road edge
ROAD_GRID_M = 0.1  # grid on which the distance to the roads is computed (detailed ground)
BLOCK_ROWS = 256  # rows of the detailed ground made at a time (each with its own white noise)
#: Log-brightness weights of the detail octaves (feature sizes 1, 2, 4, ... texels), grass
#: and road. Measured on views along a road (320 x 240, camera 0.5 m up, ORB at Kimera-Multi's
#: settings): with these the ground carries features everywhere within the depth range.
GRASS_OCTAVES = (0.08, 0.08, 0.07, 0.06, 0.05, 0.05, 0.04)
ROAD_OCTAVES = (0.10, 0.09, 0.07, 0.05, 0.04, 0.04, 0.04)
EDGE_JITTER_M = 0.3  # the road edge wanders by about this much


def plain_texture_shape(terrain: Terrain) -> tuple[int, int]:
    """(rows, cols) of the plain ground image for ``terrain``."""
    px = max(MIN_PIXEL_M, max(terrain.size_x, terrain.size_y) / MAX_TEXTURE_PX)
    return max(8, int(round(terrain.size_y / px))), max(8, int(round(terrain.size_x / px)))


def _road_distance_px(
    shape: tuple[int, int],
    size_x: float,
    size_y: float,
    roads: list[Polyline],
    cell_m: tuple[float, float] | None = None,
) -> NDArray[np.float64]:
    """Distance (metres) from every cell of a ``shape`` grid to the nearest road centre line.

    The grid starts at the world's corner (-x, +y); its cells are ``cell_m`` (x, y) metres,
    by default the world's extent divided by ``shape``.
    """
    rows, cols = shape
    mx, my = cell_m if cell_m is not None else (size_x / cols, size_y / rows)
    centre = np.zeros(shape, dtype=bool)
    for line in roads:
        seg_len = np.linalg.norm(np.diff(line, axis=0), axis=1).sum()
        t = np.linspace(0.0, 1.0, max(2, int(seg_len / (0.5 * min(mx, my))) + 2))
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
        x = np.interp(t * s[-1], s, line[:, 0])
        y = np.interp(t * s[-1], s, line[:, 1])
        c = np.clip(((x + size_x / 2) / mx).astype(int), 0, cols - 1)
        r = np.clip(((size_y / 2 - y) / my).astype(int), 0, rows - 1)
        centre[r, c] = True
    if not centre.any():
        return np.full(shape, np.inf)
    return distance_transform_edt(~centre, sampling=(my, mx))


def _road_weight(dist_m: NDArray[np.floating], road_width_m: float) -> NDArray[np.floating]:
    """1 on the road, 0 off it, a soft edge ``EDGE_M`` wide."""
    return np.clip((road_width_m / 2 - dist_m) / EDGE_M + 0.5, 0.0, 1.0)


def ground_texture(
    terrain: Terrain,
    roads: list[Polyline],
    road_width_m: float,
    rng: np.random.Generator,
    texel_m: float | None = None,
) -> NDArray[np.uint8]:
    """(rows, cols, 3) RGB ground image: grass and the road surfaces.

    ``texel_m`` None gives the plain image (patchy grass, faint noise); a texel size gives the
    detailed one (``roman_sim.world.appearance.ground_shape``).
    """
    if texel_m is not None:
        return _detailed(terrain, roads, road_width_m, rng, texel_m)
    shape = plain_texture_shape(terrain)
    coarse = rng.normal(0.0, 1.0, (max(2, shape[0] // 32), max(2, shape[1] // 32)))
    patches = zoom(coarse, (shape[0] / coarse.shape[0], shape[1] / coarse.shape[1]), order=1)[: shape[0], : shape[1]]
    fine = rng.normal(0.0, 1.0, shape)
    img = GRASS * (1.0 + 0.12 * patches[..., None]) + 10.0 * fine[..., None]
    if roads and road_width_m > 0:
        dist = _road_distance_px(shape, terrain.size_x, terrain.size_y, roads)
        w = _road_weight(dist, road_width_m)[..., None]
        img = (1 - w) * img + w * (ROAD + 6.0 * fine[..., None])
    return np.clip(img, 0, 255).astype(np.uint8)


def _lattice(rng: np.random.Generator, rows: int, cols: int, cell_px: float) -> NDArray[np.float32]:
    """Smoothed white noise on a lattice of ``cell_px`` texels covering (rows, cols), unit std, one cell of margin."""
    lat = rng.standard_normal((int(np.ceil(rows / cell_px)) + 3, int(np.ceil(cols / cell_px)) + 3), dtype=np.float32)
    lat = gaussian_filter(lat, 0.7, mode="wrap")
    return (lat / max(float(lat.std()), 1e-6)).astype(np.float32)


def _bilinear(lat: NDArray[np.float32], r0: int, r1: int, cols: int, cell_px: float) -> NDArray[np.float32]:
    """Rows ``r0:r1`` (all ``cols`` columns) of ``lat`` sampled at texel centres, ``cell_px`` texels per cell."""
    u = (np.arange(r0, r1, dtype=np.float64) + 0.5) / cell_px + 0.5  # +1 cell of margin, -0.5 to the cell centre
    v = (np.arange(cols, dtype=np.float64) + 0.5) / cell_px + 0.5
    i, j = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    fu, fv = (u - i).astype(np.float32)[:, None], (v - j).astype(np.float32)[None, :]
    rows_ = lat[i] * (1 - fu) + lat[i + 1] * fu  # (block, lattice cols)
    return (rows_[:, j] * (1 - fv) + rows_[:, j + 1] * fv).astype(np.float32, copy=False)


def _detailed(
    terrain: Terrain,
    roads: list[Polyline],
    road_width_m: float,
    rng: np.random.Generator,
    texel_m: float,
) -> NDArray[np.uint8]:
    """The detailed ground image (module docstring)."""
    rows, cols = ground_shape((terrain.size_x, terrain.size_y), texel_m)
    px_m = max(terrain.size_x / cols, terrain.size_y / rows)
    n_oct = len(GRASS_OCTAVES)
    # everything drawn up front, in a fixed order, so the image does not depend on the block size
    patches = _lattice(rng, rows, cols, PATCH_M / px_m)
    octaves = [_lattice(rng, rows, cols, float(2**k)) for k in range(1, n_oct)]
    jitter = _lattice(rng, rows, cols, 2.0 * EDGE_JITTER_M / px_m)
    block_seeds = rng.integers(0, 2**63 - 1, -(-rows // BLOCK_ROWS))
    road_dist: NDArray[np.float32] | None = None
    grid_cell = 1.0
    if roads and road_width_m > 0:
        grid_cell = float(max(1, int(round(ROAD_GRID_M / px_m))))  # texels per cell of the distance grid
        grid = (int(np.ceil(rows / grid_cell)) + 1, int(np.ceil(cols / grid_cell)) + 1)
        cell_m = (grid_cell * terrain.size_x / cols, grid_cell * terrain.size_y / rows)
        dist = _road_distance_px(grid, terrain.size_x, terrain.size_y, roads, cell_m).astype(np.float32)
        road_dist = np.pad(dist, 1, mode="edge")  # the margin cell _bilinear expects
    out = np.empty((rows, cols, 3), dtype=np.uint8)
    for b, r0 in enumerate(range(0, rows, BLOCK_ROWS)):
        r1 = min(rows, r0 + BLOCK_ROWS)
        w = np.zeros((r1 - r0, cols), np.float32)
        if road_dist is not None:
            dist = _bilinear(road_dist, r0, r1, cols, grid_cell)
            dist += EDGE_JITTER_M * _bilinear(jitter, r0, r1, cols, 2.0 * EDGE_JITTER_M / px_m)
            w = _road_weight(dist, road_width_m)
        # log-brightness: octave k weighs GRASS_OCTAVES[k] off the road, ROAD_OCTAVES[k] on it
        log = np.random.default_rng(int(block_seeds[b])).standard_normal((r1 - r0, cols), dtype=np.float32)
        log *= GRASS_OCTAVES[0] + w * (ROAD_OCTAVES[0] - GRASS_OCTAVES[0])
        for k, lat in enumerate(octaves, start=1):
            log += (GRASS_OCTAVES[k] + w * (ROAD_OCTAVES[k] - GRASS_OCTAVES[k])) * _bilinear(lat, r0, r1, cols, 2.0**k)
        shade = 1.0 + 0.12 * _bilinear(patches, r0, r1, cols, PATCH_M / px_m)
        bright = np.exp(log)
        for ch in range(3):
            colour = (1.0 - w) * (float(GRASS[ch]) * shade) + w * float(ROAD[ch])
            out[r0:r1, :, ch] = np.clip(colour * bright, 0, 255).astype(np.uint8)
    return out
