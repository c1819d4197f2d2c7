"""Paths: every kind is drivable and clear of objects; reversal, crossing; bad paths fail clearly."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import SimError
from roman_sim.core.geometry import make_T, wrap_angle
from roman_sim.sim.paths import PathConfig, crossing_path, make_path, path_from_points, reversed_path
from roman_sim.sim.planner import Obstacles
from roman_sim.world.truth import ObjectTruth, Terrain, WorldTruth


def _disc(i: int, x: float, y: float, r: float = 0.5) -> ObjectTruth:
    T = make_T(t=[x, y, 0.0])
    return ObjectTruth(i, "post", T, np.ones(3), 1.0, np.array([x, y, 0.5]), [i], [], T, np.ones(3), r)


@pytest.fixture(scope="module")
def field() -> WorldTruth:
    rng = np.random.default_rng(4)
    objs = [_disc(i, *rng.uniform(-17, 17, 2)) for i in range(40)]
    road = np.column_stack([np.linspace(-15, 15, 31), np.zeros(31) + 30.0])  # off-world road
    return WorldTruth(objs, Terrain(40.0, 40.0, np.zeros((5, 5))), roads=[road])


def _check(path, truth: WorldTruth, clearance: float = 0.6) -> None:
    assert np.all(np.abs(path.xy) <= 20.0 - 1.0 + 1e-9)
    assert Obstacles(truth).clearance(path.xy).min() >= clearance - 1e-9
    steps = np.linalg.norm(np.diff(path.xy, axis=0), axis=1)
    assert steps.max() == pytest.approx(steps.mean(), rel=0.02)  # constant arc-length spacing
    turn = np.abs(wrap_angle(np.diff(path.heading)))
    assert turn.max() < np.radians(30)  # smooth enough to drive


@pytest.mark.parametrize("kind", ["loop", "out_and_back", "lawnmower", "waypoints"])
def test_generated_paths_are_valid(field: WorldTruth, kind: str) -> None:
    cfg = PathConfig(
        kind=kind, radius_m=7.0, length_m=18.0, width_m=12.0, height_m=8.0, waypoints=[(-15.0, -15.0), (15.0, 14.0)]
    )
    path = make_path(cfg, field, np.random.default_rng(0), "r1")
    _check(path, field)
    assert path.length > 10.0


def test_loop_closes_and_out_and_back_returns(field: WorldTruth) -> None:
    loop = make_path(PathConfig(kind="loop", center=(0.0, 0.0), radius_m=6.0), field, np.random.default_rng(1))
    assert np.linalg.norm(loop.xy[0] - loop.xy[-1]) < 0.5
    oab = make_path(PathConfig(kind="out_and_back", length_m=12.0), field, np.random.default_rng(1))
    assert np.linalg.norm(oab.xy[0] - oab.xy[-1]) < 2.5
    assert oab.length > 24.0


def test_reversed_and_crossing(field: WorldTruth) -> None:
    base = make_path(PathConfig(kind="waypoints", waypoints=[(-15, -15), (15, 14)]), field, np.random.default_rng(0))
    rev = reversed_path(base)
    np.testing.assert_allclose(rev.xy[0], base.xy[-1])
    mid = len(base.xy) // 2
    j = int(np.argmin(np.linalg.norm(rev.xy - base.xy[mid], axis=1)))
    assert abs(wrap_angle(rev.heading[j] - base.heading[mid] - np.pi)) < np.radians(5)
    cross = crossing_path(base, 90.0, 0.5, 10.0)
    x, y, h = base.at(0.5 * base.length)
    assert np.min(np.linalg.norm(cross.xy - [x, y], axis=1)) < 0.05
    assert abs(wrap_angle(cross.heading[0] - h - np.pi / 2)) < 1e-6
    made = make_path(
        PathConfig(kind="cross", of="a", heading_offset_deg=120.0, length_m=20.0),
        field,
        np.random.default_rng(0),
        "b",
        {"a": base},
    )
    _check(made, field)
    again = make_path(PathConfig(kind="reverse_of", of="a"), field, np.random.default_rng(0), "b", {"a": base})
    np.testing.assert_allclose(again.xy[0], base.xy[-1])


def test_detour_around_an_object_on_the_line() -> None:
    truth = WorldTruth([_disc(0, 0.0, 0.0, 1.0)], Terrain(30.0, 30.0, np.zeros((3, 3))))
    path = make_path(PathConfig(kind="waypoints", waypoints=[(-8, 0), (8, 0)]), truth, np.random.default_rng(0))
    _check(path, truth)
    assert np.abs(path.xy[:, 1]).max() > 1.5  # went around


def test_path_leaving_the_world_names_the_robot(field: WorldTruth) -> None:
    with pytest.raises(SimError, match="robot 'scout'.*outside the world"):
        make_path(PathConfig(kind="waypoints", waypoints=[(0, 0), (30, 0)]), field, np.random.default_rng(0), "scout")
    with pytest.raises(SimError, match="'scout'.*leaves the world"):
        make_path(
            PathConfig(kind="reverse_of", of="a"),
            field,
            np.random.default_rng(0),
            "scout",
            {"a": path_from_points(np.array([[0.0, 0.0], [25.0, 0.0]]), 0.1)},
        )


def test_blocked_and_unknown_references(field: WorldTruth) -> None:
    walled = WorldTruth(
        [_disc(i, 0.0, y, 1.0) for i, y in enumerate(np.arange(-14.0, 14.5, 1.0))],
        Terrain(30.0, 30.0, np.zeros((3, 3))),
    )
    with pytest.raises(SimError, match="no free route"):
        make_path(PathConfig(kind="waypoints", waypoints=[(-8, 0), (8, 0)]), walled, np.random.default_rng(0), "r")
    with pytest.raises(SimError, match="path.of='ghost'"):
        make_path(PathConfig(kind="reverse_of", of="ghost"), field, np.random.default_rng(0), "r", {})
    with pytest.raises(SimError, match="road_index 3"):
        make_path(PathConfig(kind="road", road_index=3), field, np.random.default_rng(0), "r")
    with pytest.raises(SimError, match="path passes .* from an object"):
        make_path(
            PathConfig(kind="reverse_of", of="a"),
            field,
            np.random.default_rng(0),
            "r",
            {
                "a": path_from_points(
                    np.array(
                        [field.objects[0].T_world_obj[:2, 3] - [3, 0], field.objects[0].T_world_obj[:2, 3] + [3, 0]]
                    ),
                    0.1,
                )
            },
        )


def test_road_following_on_a_world(tiny_world) -> None:
    if not tiny_world.truth.roads:
        pytest.skip("tiny preset has no road")
    path = make_path(PathConfig(kind="road"), tiny_world.truth, np.random.default_rng(0), "r")
    assert Obstacles(tiny_world.truth).clearance(path.xy).min() >= 0.6 - 1e-9


def test_same_seed_same_path(field: WorldTruth) -> None:
    a = make_path(PathConfig(kind="loop"), field, np.random.default_rng(9))
    b = make_path(PathConfig(kind="loop"), field, np.random.default_rng(9))
    np.testing.assert_array_equal(a.xy, b.xy)


def _lateral(points: np.ndarray, line) -> np.ndarray:
    """Signed distance of ``points`` (N, 2) from ``line`` (Path2D): positive to the left of its travel."""
    from scipy.spatial import cKDTree

    dist, j = cKDTree(line.xy).query(points)
    h = line.heading[j]
    side = np.sign(np.cos(h) * (points[:, 1] - line.xy[j, 1]) - np.sin(h) * (points[:, 0] - line.xy[j, 0]))
    return side * dist


def test_revisit_drives_the_road_at_its_own_offset(tiny_world) -> None:
    """b follows a's road with a drawn offset, its own start and speed; c drives it back, offset from the centre."""
    from roman_sim.sim.robot import RobotConfig, plan_paths, trajectory_along

    robots = [
        RobotConfig(name="a", path=PathConfig(kind="road")),
        RobotConfig(
            name="b", speed_mps=0.7, path=PathConfig(kind="road", lateral_offset_m=(0.5, 1.2), start_fraction=0.3)
        ),
        RobotConfig(name="c", path=PathConfig(kind="reverse_of", of="b", lateral_offset_m=(0.8, 0.8))),
    ]
    paths = plan_paths(tiny_world, robots, seed=5)
    a, b, c = paths["a"], paths["b"], paths["c"]
    assert 0.5 <= b.offset_m <= 1.2 and c.offset_m == 0.8
    assert plan_paths(tiny_world, robots, seed=5)["b"].offset_m == b.offset_m  # seeded
    assert plan_paths(tiny_world, robots, seed=6)["b"].offset_m != b.offset_m
    assert np.linalg.norm(b.xy[0] - a.at(0.3 * a.length)[:2]) == pytest.approx(b.offset_m, abs=0.02)
    run_b = trajectory_along(tiny_world, robots[1], 5, b)
    driven = run_b.T_world_body[:, :2, 3]
    lateral = _lateral(driven, a)
    np.testing.assert_allclose(lateral, b.offset_m, atol=0.05)  # the follower tracks within 5 cm
    # c drives b's base line (a's centre line) backwards, 0.8 m to its own left = a's right
    np.testing.assert_allclose(_lateral(c.xy, a), -0.8, atol=0.02)
    assert np.cos(c.heading[0] - a.heading[int(np.argmin(np.linalg.norm(a.xy - c.xy[0], axis=1)))]) < -0.9


def test_start_fraction_starts_elsewhere_on_the_line(field: WorldTruth) -> None:
    loop = PathConfig(kind="loop", center=(0.0, 0.0), radius_m=6.0)
    whole = make_path(loop, field, np.random.default_rng(1))
    later = make_path(loop.model_copy(update={"start_fraction": 0.5}), field, np.random.default_rng(1))
    assert later.length == pytest.approx(whole.length, rel=0.01)  # a closed line is driven whole
    np.testing.assert_allclose(later.xy[0], whole.at(0.5 * whole.length)[:2], atol=0.05)
    line = PathConfig(kind="waypoints", waypoints=[(-15, -15), (15, 14)])
    part = make_path(line.model_copy(update={"start_fraction": 0.25}), field, np.random.default_rng(0))
    full = make_path(line, field, np.random.default_rng(0))
    assert part.length == pytest.approx(0.75 * full.length, rel=0.02)  # an open one from there to its end


def test_offsets_that_leave_the_road_fail_with_the_allowed_range(tiny_world) -> None:
    from roman_sim.core.config import validate_model
    from roman_sim.core.errors import ConfigError
    from roman_sim.sim.robot import RobotConfig, plan_paths

    wide = [RobotConfig(name="b", path=PathConfig(kind="road", lateral_offset_m=(0.0, 1.5)))]
    with pytest.raises(
        SimError, match=r"path.lateral_offset_m \[0.0, 1.5\] leaves the road: allowed within \[-1.4, 1.4\] m"
    ):
        plan_paths(tiny_world, wide, seed=0)
    with pytest.raises(ConfigError, match="lateral_offset_m.*low <= high"):
        validate_model(PathConfig, {"kind": "road", "lateral_offset_m": [1.0, 0.5]})
    with pytest.raises(
        SimError, match="lateral_offset_m applies to road, waypoints, reverse_of, retrace paths, not loop"
    ):
        make_path(PathConfig(kind="loop", lateral_offset_m=(0.2, 0.2)), tiny_world.truth, np.random.default_rng(0))
