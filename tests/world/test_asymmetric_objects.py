"""Objects with a front are drawn with one: houses and sheds have a door side, cars a hood and
headlights at their +x; none is its own mirror image about the vertical mid-plane across its front.

The measure (``mirror_gap``) is a point-set distance between each part's vertices and their
mirror image; a symmetric shape gives 0, which the control families show.
"""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.frontend.view_asymmetry import rasterise
from roman_sim.world.assets import FAMILIES, Part, mirror_gap
from roman_sim.world.catalog import variant_parts

VARIANTS = range(3)


def _parts(family: str, variant: int) -> dict[str, Part]:
    return {p.name: p for p in variant_parts(0, family, variant)}


@pytest.mark.parametrize("family", ["house", "shed"])
@pytest.mark.parametrize("variant", VARIANTS)
def test_a_building_has_a_door_side_and_no_mirror_plane(family: str, variant: int) -> None:
    parts = _parts(family, variant)
    assert list(parts) == ["walls", "roof", "openings"]  # the walls stay the first part
    # neither mirror maps a door or a window onto one: the gap is metres, not millimetres
    assert mirror_gap(parts.values(), 0) > 1.0
    assert mirror_gap(parts.values(), 1) > 1.0
    walls = parts["walls"].mesh.vertices
    hx, hy = walls[:, 0].max() - 1e-9, walls[:, 1].max() - 1e-9  # the faces the openings stand on
    v = parts["openings"].mesh.vertices
    door = v[v[:, 2] < 1e-9]  # the only opening down to the ground
    assert len(door) and (door[:, 0] >= hx).all()  # the door is on the front, +x
    assert ((v[:, 0] >= hx) | (v[:, 1] >= hy)).all()  # openings on the front and the +y side only


@pytest.mark.parametrize("variant", VARIANTS)
def test_a_car_has_its_front_at_plus_x_and_keeps_its_left_right_symmetry(variant: int) -> None:
    parts = _parts("car", variant)
    assert mirror_gap(parts.values(), 0) > 1.0  # front and back differ
    assert mirror_gap(parts.values(), 1) < 1e-9  # left and right mirror each other, as a real car's do
    body = parts["body"].mesh.vertices
    x0, x1 = body[:, 0].min(), body[:, 0].max()
    tip = 0.1 * (x1 - x0)
    front_top = body[body[:, 0] > x1 - tip, 2].max()
    back_top = body[body[:, 0] < x0 + tip, 2].max()
    assert front_top < back_top - 0.1  # the hood sits lower than the rear deck
    assert front_top < body[:, 2].max() - 0.5  # and far below the cabin
    assert (parts["lights"].mesh.vertices[:, 0] >= x1).all()  # the headlights are on the front face


def test_the_front_renders_its_headlights_and_the_back_does_not() -> None:
    """Rendered (the view-asymmetry rasteriser, 96 px) from the front and from the back, only the
    front shows the headlights' pale colour."""
    mesh = [(p.mesh.vertices, p.mesh.faces, np.asarray(p.rgba[:3])) for p in variant_parts(0, "car", 0)]
    lamp = np.asarray(_parts("car", 0)["lights"].rgba[:3])

    def lamp_pixels(azimuth: float) -> int:
        img = rasterise(mesh, azimuth, 96)
        hue = img / np.maximum(img.max(axis=2, keepdims=True), 1e-9)  # shading scales all channels alike
        return int((np.abs(hue - lamp / lamp.max()).max(axis=2) < 0.02).sum())

    assert lamp_pixels(np.pi) >= 4  # the camera looks along -x: the front
    assert lamp_pixels(0.0) == 0  # along +x: the back


@pytest.mark.parametrize("family", ["trash_can", "hay_bale", "fence", "log", "conifer"])
def test_the_measure_is_zero_on_a_symmetric_shape(family: str) -> None:
    """The check can fail: shapes with both mirror planes give a gap of 0."""
    assert family in FAMILIES.names()
    parts = variant_parts(0, family, 0)
    assert mirror_gap(parts, 0) < 1e-9 and mirror_gap(parts, 1) < 1e-9
