"""One robot input: a simulated robot and a recorded sequence open through one function, with an odometry file
taken the same way by either."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import write_tum
from roman_sim.interop.odometry_in import WithOdometry
from roman_sim.interop.tum_reader import TumSequence
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.scenario import Scenario, with_odometry
from roman_sim.pipeline.stages.maps_input import check_inputs, open_robot
from roman_sim.sim.source import SimulatedRobot

TINY = {
    "name": "tiny_input",
    "world": {"preset": "tiny"},
    "robots": [
        {"name": "a", "path": {"kind": "road", "road_index": 0}, "camera": {"width": 64, "height": 48}},
        {"name": "b", "path": {"kind": "reverse_of", "of": "a"}, "camera": {"width": 64, "height": 48}},
    ],
    "frontend": {"segmenter": "perfect"},
}
SHORT = {"max_duration_s": 1.0, "render_rgb": False}  # 7 frames at 6 Hz


@pytest.fixture(scope="module")
def mixed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Scenario, Any]:
    """Robot a simulated, robot b read from the TUM folder it was exported as; and the world."""
    from roman_sim.interop import export_scenario
    from roman_sim.world import generate

    data = {**TINY, "robots": [{**r, **SHORT} for r in TINY["robots"]]}
    simulated = validate_model(Scenario, data, source="tiny")
    out = tmp_path_factory.mktemp("export") / "tiny"
    export_scenario(simulated, "tum", out, robots=["b"])
    data["robots"][1] = {"name": "b", "source": {"tum": str(out / "b")}}
    return validate_model(Scenario, data, source="mixed"), generate(simulated.world.spec(), simulated.seed)


def test_either_kind_opens_through_one_function(mixed: tuple[Scenario, Any], tmp_path: Path) -> None:
    sc, world = mixed
    ctx = RunContext(sc, tmp_path)
    asked: list[str] = []

    def world_for(name: str) -> Any:
        asked.append(name)
        return world

    a, b = (open_robot(ctx, r, lambda r=r: world_for(r.name)) for r in sc.robots)
    assert asked == ["a"]  # a sequence never asks for the world
    assert isinstance(a.frames, SimulatedRobot) and isinstance(b.frames, TumSequence)
    assert (a.name, len(a.frames), b.name, len(b.frames)) == ("a", 7, "b", 7)
    assert a.world is world and b.world is None  # the whole-surface counterfactual has a world for a alone
    families = {o.id: o.family for o in world.truth.objects}
    assert a.families == families and b.families == families  # the export's object table holds the world's
    assert a.odometry == "its own, simulated (drift typical)" and b.odometry.startswith("its sequence's (")
    assert [f.index for f in b.rgb.frames([2, 5])] == [2, 5] and next(a.rgb.frames([3])).rgb is not None
    with pytest.raises(ConfigError, match="robot a: a simulated robot needs the world"):
        open_robot(ctx, sc.robots[0], lambda: None)


def test_an_odometry_file_replaces_either_kind_of_robot_s_own(mixed: tuple[Scenario, Any], tmp_path: Path) -> None:
    sc, world = mixed
    t = np.arange(7) / 6.0
    T = np.tile(np.eye(4), (7, 1, 1))
    T[:, 0, 3] = 2.0 * t  # straight ahead at 2 m/s
    write_tum(tmp_path / "odom.tum", Trajectory(t, T))
    sc = with_odometry(sc, {"a": tmp_path / "odom.tum", "b": tmp_path / "odom.tum"})
    ctx = RunContext(sc, tmp_path)
    check_inputs(ctx)  # both open before any work
    for cfg in sc.robots:
        robot = open_robot(ctx, cfg, lambda: world)
        assert isinstance(robot.frames, WithOdometry) and isinstance(robot.rgb, WithOdometry)
        assert robot.odometry.startswith(f"brought in from {tmp_path / 'odom.tum'} (body poses")
        frames = list(robot.frames.frames())
        np.testing.assert_allclose(np.stack([f.T_odom_body for f in frames]), T, atol=1e-9)
        assert all(f.truth is not None for f in frames)  # the truth stays the robot's
    (tmp_path / "odom.tum").write_text("0.0 0 0 0 0 0 0 1\n")
    with pytest.raises(ConfigError, match=r"odom.tum: covers 14% of robot a's frames \(1 of 7"):
        check_inputs(ctx)
