"""Per-robot lighting: a robot's preset changes its RGB only, exactly as the world lit that way."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.paths import PathConfig
from roman_sim.sim.render import SensorRenderer
from roman_sim.sim.robot import RobotConfig, render_trajectory
from roman_sim.sim.source import robot_sources
from roman_sim.world import World, WorldSpec, generate, load_world_spec
from roman_sim.world.appearance import LIGHTING
from roman_sim.world.relight import robot_lighting

CAM = CameraConfig(width=96, height=72)


def _world(**appearance: object) -> World:
    data = load_world_spec("tiny").model_dump(mode="json")
    data["appearance"] = {**data["appearance"], "textures": True, **appearance}
    return generate(validate_model(WorldSpec, data), 0)


def _poses() -> list[np.ndarray]:
    """Level views along +x and -y from two places (sky, ground and objects in sight)."""
    out = []
    for (x, y), fwd in (((-5.0, 0.0), (1.0, 0.0)), ((3.0, 6.0), (0.0, -1.0))):
        f = np.array([*fwd, 0.0])
        T = np.eye(4)
        T[:3, 0], T[:3, 1], T[:3, 2] = np.cross(f, [0.0, 0.0, 1.0]), [0.0, 0.0, -1.0], f
        T[:3, 3] = [x, y, 1.0]
        out.append(T)
    return out


def _render(world: World, lighting: object = None) -> list:
    with SensorRenderer(world, CAM, lighting=lighting) as r:  # type: ignore[arg-type]
        return [r.render(T) for T in _poses()]


@pytest.mark.parametrize(("preset", "shadows"), [("evening", False), ("morning", True)])
def test_a_robots_preset_relights_rgb_only_as_the_world_would(preset: str, shadows: bool) -> None:
    noon, lit_world = _world(shadows=shadows), _world(shadows=shadows, lighting=preset)
    plain = _render(noon)
    relit = _render(noon, robot_lighting(preset, 0, "b"))
    own = _render(lit_world)
    for (rgb0, d0, id0), (rgb1, d1, id1), (rgb2, _, _) in zip(plain, relit, own):
        np.testing.assert_array_equal(d1, d0)
        np.testing.assert_array_equal(id1, id0)
        assert (id0 >= 0).any() and (d0 == 0).any()  # objects and sky in view
        assert not np.array_equal(rgb1, rgb0)
        np.testing.assert_array_equal(rgb1, rgb2)
    again = _render(noon)  # the world's own look is untouched (its sky texture is restored)
    for (rgb0, _, _), (rgb3, _, _) in zip(plain, again):
        np.testing.assert_array_equal(rgb3, rgb0)


def test_random_lighting_is_drawn_per_robot_and_seeded() -> None:
    a, a2, b = robot_lighting("random", 3, "a"), robot_lighting("random", 3, "a"), robot_lighting("random", 3, "b")
    assert a is not None and a2 is not None and b is not None
    assert a.sun == a2.sun and a.sun != b.sun
    assert robot_lighting("random", 4, "a").sun != a.sun
    fixed = robot_lighting("evening", 3, "a")
    assert fixed is not None and (fixed.sun.azimuth_deg, fixed.sun.elevation_deg) == (200.0, 10.0)
    assert robot_lighting(None, 3, "a") is None


def test_render_trajectory_uses_the_robots_lighting() -> None:
    noon, evening = _world(), _world(lighting="evening")
    cfg = RobotConfig(name="b", path=PathConfig(kind="road", road_index=0), camera=CAM, max_duration_s=0.4)
    run = robot_sources(noon, [cfg], 0)[0].run
    mine = list(render_trajectory(noon, cfg.model_copy(update={"lighting": "evening"}), 0, run))
    theirs = list(render_trajectory(evening, cfg, 0, run))
    default = list(render_trajectory(noon, cfg, 0, run))
    assert len(mine) == len(theirs) == len(default) >= 2
    for f, g, h in zip(mine, theirs, default):
        np.testing.assert_array_equal(f.rgb, g.rgb)
        np.testing.assert_array_equal(f.depth, h.depth)
        np.testing.assert_array_equal(f.truth.object_ids, h.truth.object_ids)
        assert not np.array_equal(f.rgb, h.rgb)


def test_a_lighting_that_names_no_preset_is_one_line_naming_the_field() -> None:
    with pytest.raises(ConfigError) as err:
        validate_model(RobotConfig, {"name": "b", "lighting": "dusk"})
    msg = str(err.value)
    assert "\n" not in msg and "lighting: unknown lighting preset 'dusk'" in msg, msg
    assert f"valid: {', '.join(LIGHTING.names())}" in msg, msg
    assert validate_model(RobotConfig, {"name": "b", "lighting": "morning"}).lighting == "morning"
    assert RobotConfig().lighting is None


def test_a_scenario_names_the_robot_whose_lighting_is_unknown() -> None:
    from roman_sim.pipeline.scenario import load_scenario

    with pytest.raises(ConfigError) as err:
        load_scenario("visual_small", ["robots.1.lighting=dusk"])
    msg = str(err.value)
    assert "\n" not in msg and "robots.1.lighting: unknown lighting preset 'dusk'" in msg, msg
    assert load_scenario("visual_small", ["robots.2.lighting=evening"]).robots[2].lighting == "evening"
