"""Free-space queries against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import WorldError
from roman_sim.core.geometry import make_T
from roman_sim.world import World
from roman_sim.world.query import clearance, is_free, road_distance
from roman_sim.world.truth import ObjectTruth, Terrain, WorldTruth


def _obj(i: int, x: float, y: float, r: float) -> ObjectTruth:
    z3 = np.zeros(3)
    return ObjectTruth(i, "boulder", make_T(None, [x, y, 0]), z3, 0.0, z3, [], [], np.eye(4), z3, r)


@pytest.fixture
def two_discs() -> WorldTruth:
    terrain = Terrain(20.0, 20.0, np.zeros((3, 3)))
    roads = [np.array([[-10.0, -5.0], [10.0, -5.0]])]
    return WorldTruth([_obj(0, 0, 0, 1.0), _obj(1, 5, 0, 3.0)], terrain, roads)


def test_clearance_hand_values(two_discs: WorldTruth) -> None:
    pts = np.array([[0.0, 2.0], [2.5, 0.0], [0.0, 0.0], [-9.0, 0.0]])
    # (0,2): 1 from disc 0; (2.5,0): 1.5 from disc 0 but 0.5 inside disc 1; centre of disc 0: -1; far left: 8
    np.testing.assert_allclose(clearance(two_discs, pts), [1.0, -0.5, -1.0, 8.0])
    np.testing.assert_allclose(clearance(two_discs, [0.0, 2.0]), [1.0])


def test_is_free_and_margin(two_discs: WorldTruth) -> None:
    pts = np.array([[0.0, 2.0], [0.0, 2.0], [9.8, 9.8]])
    assert is_free(two_discs, pts[:1], margin=0.5).tolist() == [True]
    assert is_free(two_discs, pts[:1], margin=1.5).tolist() == [False]
    assert is_free(two_discs, pts[2:], margin=0.5).tolist() == [False]  # outside the extent


def test_road_distance(two_discs: WorldTruth) -> None:
    np.testing.assert_allclose(road_distance(two_discs, [[0.0, 0.0], [12.0, -5.0]]), [5.0, 2.0])


def test_bad_points_raise(two_discs: WorldTruth) -> None:
    with pytest.raises(WorldError, match=r"\(N, 2\)"):
        clearance(two_discs, np.zeros((3, 3)))
    with pytest.raises(WorldError):
        clearance(two_discs, [[np.nan, 0.0]])


def test_roads_of_a_world_are_free(tiny_world: World) -> None:
    road = np.concatenate(tiny_world.truth.roads)
    assert np.all(clearance(tiny_world.truth, road) >= tiny_world.spec.roads.width_m / 2 - 1e-9)
