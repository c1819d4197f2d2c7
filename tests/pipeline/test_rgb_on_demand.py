"""RGB only where it is read: the maps stage draws the colour pass for the visual keyframes alone,
and the maps and keyframes are the same bytes as with RGB on every frame."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.mapping.io import save_keyframes, save_segment_map
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages import maps_input, maps_robot
from roman_sim.sim import render
from roman_sim.sim.source import robot_sources
from roman_sim.world import generate


def _map_bytes(ctx, world, cfg, tmp_path, tag: str) -> tuple[bytes, bytes]:
    smap, kf = maps_robot.map_source(ctx, maps_input.open_robot(ctx, cfg, lambda: world))
    save_segment_map(tmp_path / f"{tag}_map.npz", smap)
    save_keyframes(tmp_path / f"{tag}_kf.npz", kf)
    return (tmp_path / f"{tag}_map.npz").read_bytes(), (tmp_path / f"{tag}_kf.npz").read_bytes()


def test_visual_keyframes_alone_get_rgb_with_the_same_outputs(tmp_path, monkeypatch) -> None:
    sc = load_scenario("visual_small", ["robots.0.max_duration_s=30"])
    world = generate(sc.world.spec(), sc.seed)
    cfg = sc.robots[0]
    ctx = RunContext(sc, tmp_path)
    run = robot_sources(world, sc.robots, sc.seed, [cfg.name])[0].run
    wanted = maps_input.rgb_frames(ctx, run.t, run.T_odom_body)
    drawn: list[bool] = []
    inner = render.SensorRenderer.render

    def spy(self, T, rgb=None):  # records whether each frame got the colour pass
        out = inner(self, T, rgb)
        drawn.append(out[0] is not None)
        return out

    monkeypatch.setattr(render.SensorRenderer, "render", spy)
    on_demand = _map_bytes(ctx, world, cfg, tmp_path, "on_demand")
    assert drawn == list(wanted) and 5 < sum(drawn) < len(drawn) / 3
    monkeypatch.setattr(maps_input, "rgb_frames", lambda ctx, t, T: None)  # RGB on every frame
    drawn.clear()
    assert _map_bytes(ctx, world, cfg, tmp_path, "every_frame") == on_demand
    assert all(drawn) and len(drawn) == len(wanted)


@pytest.mark.parametrize(
    ("name", "sets", "expected"),
    [
        ("demo_pixels", [], "all"),  # the image front end reads every frame's RGB
        ("visual_small", ["record_frames=true"], "all"),  # a recording keeps every frame's RGB
        ("opposite_small", [], "none"),  # nothing reads RGB
    ],
)
def test_rgb_for_front_ends_recordings_and_nobody(name, sets, expected, tmp_path, monkeypatch) -> None:
    sc = load_scenario(name, sets)
    world = generate(sc.world.spec(), sc.seed)
    robots = [r.model_copy(update={"max_duration_s": 2.0, "render_rgb": True}) for r in sc.robots]
    sc = sc.model_copy(update={"robots": robots})
    frames = list(maps_input.open_robot(RunContext(sc, tmp_path), sc.robots[0], lambda: world).frames.frames())
    got = [f.rgb is not None for f in frames]
    assert got == [expected == "all"] * len(frames) and len(frames) > 3
    assert all(np.asarray(f.depth).any() for f in frames)
