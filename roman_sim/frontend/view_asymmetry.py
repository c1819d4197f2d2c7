"""How different a shape looks from opposite sides: the energy of the encoder's view part.

A shape (its parts' meshes and colours in the object frame) is rasterised orthographically,
with a z-buffer and a headlight shading, from ``AZIMUTHS`` horizontal directions round it into
``SIZE`` x ``SIZE`` images framed on the shape. Its asymmetry is the mean, over the
directions, of the relative L1 difference between the view from one side and the mirrored
view from the opposite side,

    d = mean_psi  sum |I(psi) - flip(I(psi + 180))| / sum (I(psi) + flip(I(psi + 180))),

in [0, 1]: 0 when the far side is the near side's mirror image (a cone, a cylinder: the
silhouette and colours a CLIP-like encoder sees, which is close to mirror-invariant, do not
change), larger when the sides differ (a car's bonnet and boot, a bench's seat and backrest,
a house's door). Everything is deterministic and cheap (a few milliseconds per shape); the
per-family values of the built-in families are in ``docs/mapping.md``.

``rasterise`` can also draw a shape under a ``Light`` (a directional sun with ambient and
headlight terms, the world's lighting equation): ``benchmarks/measure_lighting.py`` measures
the encoder's lighting term with it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Horizontal viewing directions round the shape, and the side of each image in pixels.
AZIMUTHS, SIZE = 8, 40
#: The images are compared in POOL x POOL blocks: what differs is the shape's layout, not its
#: outline's pixel detail.
POOL = 4
#: Light on every face alike and from the camera (the shading's two terms).
AMBIENT, HEADLIGHT = 0.35, 0.65

Mesh = tuple[NDArray[np.float64], NDArray[np.int64], Sequence[float]]


@dataclass(frozen=True)
class Light:
    """A directional sun, an ambient term and a headlight, drawn as ``world.appearance.LightingSpec``
    says: colour times ``ambient + headlight * cos(view angle) + sun * cos(sun angle)``, clipped at 1.

    Attributes:
        towards: unit vector from the shape towards the sun, in the object frame.
        sun: the sun's RGB intensity (its intensity times its colour).
        ambient: light on every face alike.
        headlight: diffuse light from the camera.
    """

    towards: tuple[float, float, float]
    sun: tuple[float, float, float]
    ambient: float
    headlight: float


def rasterise(
    parts: Sequence[Mesh],
    azimuth: float,
    size: int = SIZE,
    half_m: float | None = None,
    light: Light | None = None,
) -> NDArray[np.float64]:
    """(size, size, 3) orthographic image of ``parts`` (vertices, faces, RGB) seen along
    horizontal direction ``azimuth`` (rad, object frame, camera -> object), framed on the shape
    (or on a square of half-side ``half_m`` metres about its middle height).

    Shading: ``AMBIENT + HEADLIGHT * cos(view angle)`` without ``light``; with it, the
    light's terms, the sun lighting the side of each face the camera sees (a face turned
    away from the sun gets ambient and headlight only), clipped at 1."""
    verts = np.concatenate([np.asarray(v, np.float64) for v, _, _ in parts])
    tri = np.concatenate([np.asarray(v, np.float64)[np.asarray(f)] for v, f, _ in parts])
    rgb = np.concatenate([np.tile(np.asarray(c, np.float64)[:3], (len(f), 1)) for _, f, c in parts])
    d = np.array([np.cos(azimuth), np.sin(azimuth), 0.0])
    right = np.array([np.sin(azimuth), -np.cos(azimuth), 0.0])  # image columns run left to right
    z0, z1 = float(verts[:, 2].min()), float(verts[:, 2].max())
    half = half_m or max(float(np.hypot(verts[:, 0], verts[:, 1]).max()), (z1 - z0) / 2, 1e-6)
    x = ((tri @ right) / half + 1) * size / 2  # (T, 3) pixel columns of the corners
    y = (((z0 + z1) / 2 - tri[:, :, 2]) / half + 1) * size / 2
    z = tri @ d
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1)
    if light is None:
        shade = AMBIENT + HEADLIGHT * np.abs(n @ d) / np.where(norm > 0, norm, 1.0)
    else:
        shade = _lit(n, norm, d, light)
    px = (np.arange(size * size) % size + 0.5)[None, :]
    py = (np.arange(size * size) // size + 0.5)[None, :]
    det = (y[:, 1] - y[:, 2]) * (x[:, 0] - x[:, 2]) + (x[:, 2] - x[:, 1]) * (y[:, 0] - y[:, 2])
    ok = np.abs(det) > 1e-12
    det = np.where(ok, det, 1.0)[:, None]
    a = ((y[:, 1:2] - y[:, 2:3]) * (px - x[:, 2:3]) + (x[:, 2:3] - x[:, 1:2]) * (py - y[:, 2:3])) / det
    b = ((y[:, 2:3] - y[:, 0:1]) * (px - x[:, 2:3]) + (x[:, 0:1] - x[:, 2:3]) * (py - y[:, 2:3])) / det
    c = 1.0 - a - b
    inside = ok[:, None] & (a >= -1e-9) & (b >= -1e-9) & (c >= -1e-9)
    depth = np.where(inside, a * z[:, 0:1] + b * z[:, 1:2] + c * z[:, 2:3], np.inf)  # (T, P)
    near = np.argmin(depth, axis=0)
    hit = np.isfinite(depth[near, np.arange(depth.shape[1])])
    if light is None:
        img = np.where(hit[:, None], rgb[near] * shade[near][:, None], 0.0)
    else:
        img = np.where(hit[:, None], np.clip(rgb[near] * shade[near], 0.0, 1.0), 0.0)
    return img.reshape(size, size, 3)


def _lit(
    n: NDArray[np.float64], norm: NDArray[np.float64], d: NDArray[np.float64], light: Light
) -> NDArray[np.float64]:
    """(T, 3) shading of faces with normals ``n`` (lengths ``norm``) seen along ``d`` under ``light``."""
    unit = n / np.where(norm > 0, norm, 1.0)[:, None]
    facing = np.abs(unit @ d)  # cosine of the view angle
    seen = -np.sign(unit @ d)[:, None] * unit  # normal of the side the camera sees
    sun = np.clip(seen @ np.asarray(light.towards, np.float64), 0.0, None)
    return light.ambient + light.headlight * facing[:, None] + sun[:, None] * np.asarray(light.sun, np.float64)[None, :]


def asymmetry(parts: Sequence[Mesh]) -> float:
    """The shape's front-back asymmetry ``d`` in [0, 1] (the module docstring)."""
    s = SIZE // POOL
    views = [
        rasterise(parts, 2 * np.pi * k / AZIMUTHS).reshape(s, POOL, s, POOL, 3).mean(axis=(1, 3))
        for k in range(AZIMUTHS)
    ]
    out = []
    for k in range(AZIMUTHS):
        a, b = views[k], views[(k + AZIMUTHS // 2) % AZIMUTHS]
        total = float((a + b).sum())
        out.append(float(np.abs(a - b).sum()) / total if total > 0 else 0.0)
    return float(np.mean(out))
