"""The screened oriented-box search against trimesh's ``oriented_bounds``: the same extents, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.frontend.segmenter import simulated_segmenter
from roman_sim.mapping import synthetic
from roman_sim.mapping.mapper import Mapper
from roman_sim.mapping.obb import oriented_extents, trimesh_extents
from roman_sim.mapping.tracker import MappingConfig


def _result(fn, points):
    try:
        return np.sort(fn(points))
    except Exception as err:  # the same failure counts as the same answer
        return type(err)


def _assert_same(points) -> None:
    a, b = _result(trimesh_extents, points), _result(oriented_extents, points)
    if isinstance(a, type) or isinstance(b, type):
        assert a == b
    else:
        np.testing.assert_array_equal(a, b)


def _clouds(seed: int) -> list[np.ndarray]:
    """Boxes, flat and slanted planes, lattices (many tied directions), far from the origin."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(60):
        p = rng.standard_normal((int(rng.integers(5, 300)), 3)) * rng.uniform(0.05, 3, 3)
        kind = k % 5
        if kind == 1:
            p[:, 2] = 0.0
        elif kind == 2:
            p = np.round(p / 0.05) * 0.05
        elif kind == 3:
            p = np.round(rng.uniform(0, 1, p.shape) * 3) / 3
        elif kind == 4:
            p[:, 1] = 2 * p[:, 0]
        R = np.linalg.qr(rng.standard_normal((3, 3)))[0]
        out.append(p @ R.T + rng.uniform(-300, 300, 3))
    return out


@pytest.mark.parametrize("seed", [0, 1])
def test_same_extents_as_trimesh_on_shapes_with_ties(seed: int) -> None:
    for points in _clouds(seed):
        _assert_same(points)


def test_same_extents_as_trimesh_on_mapped_segments() -> None:
    """Segments of ray-cast frames: dense voxel clouds of spheres seen from a moving camera."""
    spheres = synthetic.sphere_field(60, 3, x_range=(2.0, 8.0), half_width=3.0, radius_range=(0.2, 0.5))
    frames = synthetic.drive(spheres, n=15, speed=0.4, intr=synthetic.intrinsics(160, 120, 87.0))
    mapper = Mapper(MappingConfig(), simulated_segmenter("perfect", 3))
    for frame in frames:
        mapper.process(frame)
    segments = mapper.finish().segments
    assert len(segments) >= 5
    for s in segments:
        _assert_same(s.points)
        assert s.volume == float(np.prod(np.sort(trimesh_extents(s.points))[::-1]))  # what obb_extents computed
