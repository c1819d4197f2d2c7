"""Parametric object families built with trimesh.

Each family builder takes a Generator and returns a few coloured parts (one MuJoCo geom
each) in the object frame: origin at the base centre, z up, resting on z = 0. Meshes are
light (tens to a few hundred faces) so 1000-object worlds render fast. Each part names its
surface kind (``roman_sim.world.textures.SURFACES``: texture and colour range), the axis its
grain runs along, and optionally a colour range of its own.

An object whose real counterpart has a front faces +x in its own frame and is drawn
asymmetric: a house's and a shed's door is on the +x face (windows on some faces only), a car's
hood and headlights are at +x. ``mirror_gap`` measures how far a shape is from its mirror image.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from roman_sim.core.geometry import make_T, rot_x, rot_y
from roman_sim.core.registry import Registry
from roman_sim.world.appearance import Variation

Rgba = tuple[float, float, float, float]


@dataclass(frozen=True)
class Part:
    """One coloured piece of an object (becomes one geom)."""

    name: str
    mesh: trimesh.Trimesh
    rgba: Rgba
    surface: str = "paint"  # surface kind: texture, tile size, colour range
    grain_axis: int = 2  # object axis the texture's streaks or grain follow
    variation: Variation | None = None  # colour range; None: the surface kind's


Builder = Callable[[np.random.Generator], list[Part]]
FAMILIES: Registry[Builder] = Registry("family")

BARK: Rgba = (0.40, 0.27, 0.16, 1.0)
WOOD: Rgba = (0.55, 0.38, 0.22, 1.0)
METAL: Rgba = (0.25, 0.25, 0.28, 1.0)
ANY_HUE = Variation(180.0, 0.2, 0.25)  # man-made objects painted in any colour


def _cyl(r: float, h: float, sections: int = 8, z0: float = 0.0) -> trimesh.Trimesh:
    m = trimesh.creation.cylinder(radius=r, height=h, sections=sections)
    m.apply_translation([0.0, 0.0, z0 + h / 2])
    return m


def _box(ex: float, ey: float, ez: float, x: float = 0.0, y: float = 0.0, z0: float = 0.0) -> trimesh.Trimesh:
    m = trimesh.creation.box(extents=[ex, ey, ez])
    m.apply_translation([x, y, z0 + ez / 2])
    return m


def _blob(rng: np.random.Generator, rx: float, ry: float, rz: float, z0: float, noise: float) -> trimesh.Trimesh:
    """A jittered ellipsoid (icosphere, 80 faces) whose lowest point sits at ``z0``."""
    m = trimesh.creation.icosphere(subdivisions=1)
    v = m.vertices * (1.0 + noise * rng.uniform(-1.0, 1.0, (len(m.vertices), 1)))
    v = v * np.array([rx, ry, rz])
    v[:, 2] += z0 - v[:, 2].min()
    return trimesh.Trimesh(v, m.faces, process=False)


def concat_meshes(meshes: Iterable[trimesh.Trimesh]) -> trimesh.Trimesh:
    """``meshes`` as one triangle mesh (``trimesh.util.concatenate``, typed for triangle meshes)."""
    out = trimesh.util.concatenate(list(meshes))
    assert isinstance(out, trimesh.Trimesh)  # triangle meshes (or none) concatenate to a triangle mesh
    return out


def _cat(*meshes: trimesh.Trimesh) -> trimesh.Trimesh:
    return concat_meshes(meshes)


@FAMILIES.register("conifer")
def conifer(rng: np.random.Generator) -> list[Part]:
    h = rng.uniform(6.0, 10.0)
    trunk_h = h * rng.uniform(0.12, 0.2)
    r = h * rng.uniform(0.2, 0.28)
    crown = _cat(
        *(
            trimesh.creation.cone(radius=r * (1 - 0.3 * k), height=(h - trunk_h) * 0.6, sections=10).apply_translation(
                [0, 0, trunk_h + k * (h - trunk_h) * 0.2]
            )
            for k in range(3)
        )
    )
    return [
        Part("trunk", _cyl(0.1 + 0.024 * h, trunk_h + 0.3), BARK, "bark"),
        Part("crown", crown, (0.10, 0.33, 0.16, 1.0), "foliage"),
    ]


@FAMILIES.register("deciduous")
def deciduous(rng: np.random.Generator) -> list[Part]:
    trunk_h = rng.uniform(1.8, 3.0)
    cr = rng.uniform(1.8, 2.8)
    crown = _blob(rng, cr, cr * rng.uniform(0.85, 1.0), cr * rng.uniform(0.8, 1.1), trunk_h - 0.3, 0.12)
    return [
        Part("trunk", _cyl(0.18, trunk_h + 0.2), BARK, "bark"),
        Part("crown", crown, (0.30, 0.52, 0.18, 1.0), "foliage"),
    ]


@FAMILIES.register("bush")
def bush(rng: np.random.Generator) -> list[Part]:
    r = rng.uniform(0.6, 1.1)
    body = _blob(rng, r, r * rng.uniform(0.7, 1.0), r * rng.uniform(0.6, 0.9), 0.0, 0.15)
    return [Part("body", body, (0.22, 0.45, 0.15, 1.0), "foliage")]


@FAMILIES.register("boulder")
def boulder(rng: np.random.Generator) -> list[Part]:
    r = rng.uniform(0.5, 1.2)
    m = _blob(rng, r, r * rng.uniform(0.6, 1.0), r * rng.uniform(0.4, 0.8), 0.0, 0.2)
    return [Part("body", m, (0.50, 0.49, 0.46, 1.0), "rock")]


@FAMILIES.register("stump")
def stump(rng: np.random.Generator) -> list[Part]:
    return [Part("body", _cyl(rng.uniform(0.25, 0.45), rng.uniform(0.3, 0.7), sections=10), WOOD, "wood")]


@FAMILIES.register("log")
def log(rng: np.random.Generator) -> list[Part]:
    r, length = rng.uniform(0.15, 0.3), rng.uniform(2.0, 4.0)
    m = trimesh.creation.cylinder(radius=r, height=length, sections=8)
    m.apply_transform(make_T(rot_y(np.pi / 2), [0.0, 0.0, r]))
    return [Part("body", m, BARK, "bark", grain_axis=0)]


def _gable_roof(w: float, d: float, h: float, z0: float, overhang: float = 0.3) -> trimesh.Trimesh:
    """A triangular prism along x: a gable roof of width ``w`` (x) and depth ``d`` (y)."""
    hw, hd = w / 2 + overhang, d / 2 + overhang
    v = np.array([[-hw, -hd, 0], [-hw, hd, 0], [-hw, 0, h], [hw, -hd, 0], [hw, hd, 0], [hw, 0, h]]) + [0, 0, z0]
    f = np.array([[0, 2, 1], [3, 4, 5], [0, 3, 5], [0, 5, 2], [1, 2, 5], [1, 5, 4], [0, 1, 4], [0, 4, 3]])
    m = trimesh.Trimesh(v, f, process=False)
    m.fix_normals()
    return m


def _on_face(axis: int, half: float, wide: float, tall: float, at: float, z0: float, proud: float) -> trimesh.Trimesh:
    """A thin box (door, window, lamp) ``proud`` metres out from the +``axis`` face (0: x, 1: y) of a
    box reaching ``half`` along that axis: ``wide`` along the face, centred at ``at``, from ``z0`` up ``tall``."""
    out = half + proud / 2
    if axis == 0:
        return _box(proud, wide, tall, x=out, y=at, z0=z0)
    return _box(wide, proud, tall, x=at, y=out, z0=z0)


OPENINGS: Rgba = (0.16, 0.18, 0.22, 1.0)  # doors and window panes, dark against any wall
OPENINGS_PROUD_M = 0.06  # how far doors and windows stand out of their wall


@FAMILIES.register("house")
def house(rng: np.random.Generator) -> list[Part]:
    """Walls under a gable roof (ridge along x). The front is the +x gable end: a door off centre and
    a window beside it; the +y side has two windows, the back (-x) and the -y side none; a chimney
    rises through the -y slope in the front half. Neither vertical mid-plane mirrors the house onto
    itself."""
    w, d, h = rng.uniform(7.0, 11.0), rng.uniform(6.0, 9.0), rng.uniform(3.0, 5.5)
    wall = tuple(rng.uniform(0.65, 0.9, 3)) + (1.0,)
    roof = _gable_roof(w, d, rng.uniform(1.5, 3.0), h)
    door_y = d * rng.uniform(0.15, 0.3)
    sill, pane = 0.9, min(1.2, h - 1.3)
    openings = _cat(
        _on_face(0, w / 2, 1.0, min(2.1, h - 0.5), door_y, 0.0, OPENINGS_PROUD_M),
        _on_face(0, w / 2, 1.2, pane, -door_y, sill, OPENINGS_PROUD_M),
        *(_on_face(1, d / 2, 1.4, pane, sx * w / 4, sill, OPENINGS_PROUD_M) for sx in (-1, 1)),
    )
    roof_h = float(roof.vertices[:, 2].max()) - h
    chimney = _box(0.7, 0.7, roof_h + 0.6, x=w / 4, y=-d / 4, z0=h)  # rises through the -y slope, front half
    return [
        Part("walls", _cat(_box(w, d, h), chimney), wall, "paint"),
        Part("roof", roof, (0.55, 0.18, 0.12, 1.0), "tiles"),
        Part("openings", openings, OPENINGS, "paint"),
    ]


@FAMILIES.register("shed")
def shed(rng: np.random.Generator) -> list[Part]:
    """Walls under a gable roof (ridge along x); the front (+x) has a door off centre, the +y side one
    window off centre, the back and the -y side none."""
    w, d, h = rng.uniform(2.5, 4.0), rng.uniform(2.0, 3.0), rng.uniform(2.0, 2.6)
    door_y = d * rng.uniform(0.12, 0.22)
    openings = _cat(
        _on_face(0, w / 2, 0.8, min(1.9, h - 0.2), door_y, 0.0, OPENINGS_PROUD_M),
        _on_face(1, d / 2, 0.8, 0.6, -0.15 * w, 1.0, OPENINGS_PROUD_M),
    )
    return [
        Part("walls", _box(w, d, h), WOOD, "wood"),
        Part("roof", _gable_roof(w, d, 0.8, h, 0.15), (0.3, 0.3, 0.32, 1.0), "metal"),
        Part("openings", openings, OPENINGS, "paint"),
    ]


HEADLIGHTS: Rgba = (0.95, 0.93, 0.78, 1.0)
LAMP_RANGE = Variation(2.0, 0.02, 0.03)  # headlights look alike on every car


@FAMILIES.register("car")
def car(rng: np.random.Generator) -> list[Part]:
    """A car whose front is +x: the hood (top 0.85 m) lower than the rear deck (1.0 m) and the cabin
    (1.55 m), the cabin set back, two headlights on the front face. Left and right mirror each other,
    as a real car's do; front and back do not."""
    length, width = rng.uniform(3.8, 4.8), rng.uniform(1.7, 1.9)
    split = 0.2 * length  # where the hood meets the windscreen
    rear = _box(length / 2 + split, width, 0.7, x=(split - length / 2) / 2, z0=0.3)
    hood = _box(length / 2 - split, width, 0.55, x=(split + length / 2) / 2, z0=0.3)
    body = _cat(rear, hood, _box(length * 0.55, width * 0.9, 0.55, x=-0.1 * length, z0=1.0))
    wheels = _cat(
        *(
            trimesh.creation.cylinder(radius=0.32, height=0.25, sections=8).apply_transform(
                make_T(rot_x(np.pi / 2), [sx * length * 0.33, sy * width * 0.45, 0.32])
            )
            for sx in (-1, 1)
            for sy in (-1, 1)
        )
    )
    lamps = _cat(*(_on_face(0, length / 2, 0.32, 0.14, sy * (width / 2 - 0.28), 0.62, 0.03) for sy in (-1, 1)))
    colour = tuple(rng.uniform(0.1, 0.9, 3)) + (1.0,)
    return [
        Part("body", body, colour, "paint", variation=ANY_HUE),
        Part("wheels", wheels, (0.08, 0.08, 0.08, 1.0), "metal"),
        Part("lights", lamps, HEADLIGHTS, "paint", variation=LAMP_RANGE),
    ]


@FAMILIES.register("lamp_post")
def lamp_post(rng: np.random.Generator) -> list[Part]:
    h = rng.uniform(4.0, 6.0)
    head = _box(0.9, 0.3, 0.25, x=0.35, z0=h)
    return [
        Part("pole", _cyl(0.08, h + 0.1, sections=6), METAL, "metal"),
        Part("lamp", head, (0.95, 0.92, 0.7, 1.0), "paint"),
    ]


@FAMILIES.register("bench")
def bench(rng: np.random.Generator) -> list[Part]:
    length = rng.uniform(1.5, 2.2)
    seat = _box(length, 0.45, 0.06, z0=0.42)
    back = _box(length, 0.06, 0.4, y=0.22, z0=0.5)
    legs = [_box(0.06, 0.45, 0.42, x=s * (length / 2 - 0.1)) for s in (-1, 1)]
    return [Part("body", _cat(seat, back, *legs), WOOD, "wood", grain_axis=0)]


@FAMILIES.register("fence")
def fence(rng: np.random.Generator) -> list[Part]:
    length, h = rng.uniform(3.0, 6.0), rng.uniform(0.9, 1.4)
    n_posts = round(length / 1.5) + 1
    posts = [_box(0.1, 0.1, h, x=x) for x in np.linspace(-length / 2, length / 2, n_posts)]
    rails = [_box(length, 0.04, 0.1, z0=z) for z in (0.3 * h, 0.75 * h)]
    return [Part("body", _cat(*posts, *rails), (0.62, 0.50, 0.36, 1.0), "wood")]


@FAMILIES.register("trash_can")
def trash_can(rng: np.random.Generator) -> list[Part]:
    body = _cyl(rng.uniform(0.25, 0.35), rng.uniform(0.8, 1.1), sections=10)
    return [Part("body", body, (0.15, 0.35, 0.2, 1.0), "paint")]


@FAMILIES.register("hay_bale")
def hay_bale(rng: np.random.Generator) -> list[Part]:
    r = rng.uniform(0.6, 0.8)
    m = trimesh.creation.cylinder(radius=r, height=rng.uniform(1.1, 1.5), sections=12)
    m.apply_transform(make_T(rot_x(np.pi / 2), [0.0, 0.0, r]))
    return [Part("body", m, (0.85, 0.75, 0.35, 1.0), "straw")]


def mirror_gap(parts: Iterable[Part], axis: int) -> float:
    """How far ``parts`` are from their mirror image about the vertical mid-plane across ``axis``
    (0: x -> -x, 1: y -> -y, about the middle of the parts' bounds): the largest over parts of the
    symmetric Hausdorff distance (m) between a part's vertices and its mirrored vertices. 0 for a
    mirror-symmetric shape whose mirror maps vertices onto vertices (boxes, regular prisms)."""
    parts = list(parts)
    v = np.concatenate([p.mesh.vertices for p in parts])
    mid = (v[:, axis].min() + v[:, axis].max()) / 2
    gap = 0.0
    for p in parts:
        a = np.asarray(p.mesh.vertices, dtype=np.float64)
        b = a.copy()
        b[:, axis] = 2 * mid - b[:, axis]
        gap = max(gap, float(cKDTree(a).query(b)[0].max()), float(cKDTree(b).query(a)[0].max()))
    return gap
