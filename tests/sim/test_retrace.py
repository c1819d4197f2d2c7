"""``retrace`` paths: pieces of another robot's path, forward or backward, joined by routes."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import SimError
from roman_sim.core.geometry import make_T, wrap_angle
from roman_sim.sim.paths import PathConfig, make_path
from roman_sim.sim.planner import Obstacles
from roman_sim.world.truth import ObjectTruth, Terrain, WorldTruth


def _post(i: int, x: float, y: float) -> ObjectTruth:
    T = make_T(t=[x, y, 0.0])
    return ObjectTruth(i, "post", T, np.ones(3), 1.0, np.array([x, y, 0.5]), [i], [], T, np.ones(3), 0.5)


@pytest.fixture(scope="module")
def world_and_loop():
    objs = [_post(0, 0.0, 0.0), _post(1, 3.0, -2.0), _post(2, -4.0, 3.0)]  # inside the loop
    truth = WorldTruth(objs, Terrain(40.0, 40.0, np.zeros((5, 5))))
    loop = make_path(
        PathConfig(kind="loop", center=(0.0, 0.0), radius_m=12.0, aspect=0.8), truth, np.random.default_rng(0), "a"
    )
    return truth, loop


def _heading_near(path, xy):
    j = int(np.argmin(np.linalg.norm(path.xy - xy, axis=1)))
    return path.heading[j], float(np.linalg.norm(path.xy[j] - xy))


def test_half_along_half_against(world_and_loop):
    truth, loop = world_and_loop
    cfg = PathConfig(kind="retrace", of="a", pieces=[(0.0, 0.5), (1.0, 0.5)])
    b = make_path(cfg, truth, np.random.default_rng(0), "b", {"a": loop})
    assert Obstacles(truth).clearance(b.xy).min() >= cfg.clearance_m - 1e-9
    # first quarter of a: b drives it in the same direction; third quarter: against it
    for frac, expected in ((0.25, 0.0), (0.75, np.pi)):
        x, y, h = loop.at(frac * loop.length)
        hb, dist = _heading_near(b, [x, y])
        assert dist < 0.1
        assert abs(wrap_angle(hb - h - expected)) < np.radians(10)
    assert b.length > loop.length  # both halves plus the connection across the loop


def test_bad_pieces_name_the_robot(world_and_loop):
    truth, loop = world_and_loop
    with pytest.raises(SimError, match=r"robot 'b': path.pieces\[1\]"):
        make_path(
            PathConfig(kind="retrace", of="a", pieces=[(0.0, 0.5), (0.5, 0.5)]),
            truth,
            np.random.default_rng(0),
            "b",
            {"a": loop},
        )
    with pytest.raises(SimError, match="not an earlier robot"):
        make_path(PathConfig(kind="retrace", of="zz"), truth, np.random.default_rng(0), "b", {"a": loop})


def test_u_turn_is_driven_on_the_spot(world_and_loop):
    """Driving forward then back along the same curve: the controller turns around in place."""
    from roman_sim.sim.kinematics import PathFollower, PlanarState, integrate_unicycle

    truth, loop = world_and_loop
    b = make_path(
        PathConfig(kind="retrace", of="a", pieces=[(0.0, 0.3), (0.3, 0.1)]),
        truth,
        np.random.default_rng(0),
        "b",
        {"a": loop},
    )
    follower = PathFollower(b, 1.0, 0.6, 1.5)
    st = PlanarState(float(b.xy[0, 0]), float(b.xy[0, 1]), float(b.heading[0]))
    worst = 0.0
    for _ in range(20000):
        if follower.done:
            break
        v, w = follower.act(st.x, st.y, st.heading)
        st = integrate_unicycle(st, v, w, 0.02)
        worst = max(worst, float(np.min(np.linalg.norm(b.xy - [st.x, st.y], axis=1))))
    assert follower.done
    assert np.hypot(st.x - b.xy[-1, 0], st.y - b.xy[-1, 1]) < 0.2
    assert worst < 0.5  # never strays far from the path, even at the U-turn
