"""The rasteriser's shading: the default headlight and a directional sun (``view_asymmetry.Light``)."""

import math

import numpy as np
import pytest

from roman_sim.frontend.view_asymmetry import AMBIENT, HEADLIGHT, Light, rasterise
from roman_sim.world.catalog import variant_parts

RGB = (0.8, 0.5, 0.2)
SUN = (0.5, 0.5, 0.5)


def _wall(flip: bool = False) -> list:
    """A 2 m square in the plane x = 0 (normal along x), one colour; ``flip`` reverses its winding."""
    v = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 2.0], [0.0, -1.0, 2.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    return [(v, f[:, ::-1] if flip else f, RGB)]


def _lit(img: np.ndarray) -> np.ndarray:
    """The colours of the pixels the shape covers (one colour expected)."""
    px = img[img.sum(axis=2) > 0]
    assert len(px) > 0
    assert float(np.abs(px - px[0]).max()) < 1e-12
    return px[0]


@pytest.mark.parametrize("azimuth", [0.0, math.pi / 3, math.pi])
def test_default_shading_is_ambient_plus_headlight_by_the_view_cosine(azimuth):
    got = _lit(rasterise(_wall(), azimuth, 24))
    np.testing.assert_allclose(got, np.array(RGB) * (AMBIENT + HEADLIGHT * abs(math.cos(azimuth))), atol=1e-12)


def test_a_sunless_light_with_the_default_terms_draws_the_default_image():
    mesh = [(p.mesh.vertices, p.mesh.faces, np.asarray(p.rgba[:3])) for p in variant_parts(0, "car", 0)]
    light = Light((1.0, 0.0, 0.0), (0.0, 0.0, 0.0), AMBIENT, HEADLIGHT)
    for az in (0.0, 1.3, 3.9):
        np.testing.assert_allclose(rasterise(mesh, az, 40, light=light), rasterise(mesh, az, 40), atol=1e-12)


@pytest.mark.parametrize("flip", [False, True])
def test_a_face_lit_head_on_is_brighter_than_the_same_face_lit_from_behind(flip):
    """Camera at +x looking along -x (azimuth pi); the sun behind the camera, then behind the wall."""
    az = math.pi
    front = _lit(rasterise(_wall(flip), az, 24, light=Light((1.0, 0.0, 0.0), SUN, 0.3, 0.2)))
    back = _lit(rasterise(_wall(flip), az, 24, light=Light((-1.0, 0.0, 0.0), SUN, 0.3, 0.2)))
    np.testing.assert_allclose(front, np.array(RGB) * (0.3 + 0.2 + 0.5), atol=1e-12)
    np.testing.assert_allclose(back, np.array(RGB) * (0.3 + 0.2), atol=1e-12)  # its own shadow: no sun


def test_the_sun_lights_by_the_cosine_of_its_angle_and_clips_at_one():
    az = math.pi
    slant = Light((math.cos(math.pi / 3), math.sin(math.pi / 3), 0.0), SUN, 0.3, 0.2)
    np.testing.assert_allclose(
        _lit(rasterise(_wall(), az, 24, light=slant)), np.array(RGB) * (0.5 + 0.5 * 0.5), atol=1e-12
    )
    glare = _lit(rasterise(_wall(), az, 24, light=Light((1.0, 0.0, 0.0), (2.0, 2.0, 2.0), 0.3, 0.2)))
    np.testing.assert_allclose(glare, np.minimum(np.array(RGB) * 2.5, 1.0), atol=1e-12)
