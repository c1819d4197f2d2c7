"""Stage ``maps``: simulate every robot and map its frames into a ``SegmentMap``.

Robots are planned together (a path may be defined relative to an earlier robot's), then
rendered and mapped one by one; each robot's map is written as soon as it is finished.
When a scenario lists the ``visual`` method, the same frames also give each robot's visual
keyframes (ORB features with depth and BoW vectors, ``frontend.keyframes``), saved as
``keyframes/<robot>.npz`` with poses in the robot's odometry frame.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from roman_sim.align.visual import KeyframeExtractor, default_vocabulary
from roman_sim.core.config import stable_hash
from roman_sim.core.errors import ConfigError, RomanSimError
from roman_sim.core.registry import import_object
from roman_sim.mapping.io import load_keyframes, load_segment_map, save_keyframes, save_segment_map
from roman_sim.mapping.mapper import Mapper, SegmentMap
from roman_sim.mapping.segmenter import SegmenterConfig, build_segmenter
from roman_sim.mapping.semantics import SimulatedEncoder
from roman_sim.mapping.types import KeyframeSet
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.notes import load_per_robot, save_per_robot
from roman_sim.pipeline.stages.world import WorldOutput
from roman_sim.sensors import Frame

log = logging.getLogger(__name__)


@dataclass
class Maps:
    """Each robot's segment map (robot name -> map, in scenario order), the stage's notes and,
    when the visual method runs, each robot's keyframes (poses in its odometry frame)."""

    maps: dict[str, SegmentMap]
    notes: list[str] = field(default_factory=list)
    keyframes: dict[str, KeyframeSet] = field(default_factory=dict)


def _user_object(path: str, kind: str, **kwargs: Any) -> Any:
    factory = import_object(path, kind)
    try:
        return factory(**kwargs) if callable(factory) else factory
    except TypeError as err:
        raise ConfigError(f"{kind} {path!r}: cannot construct it ({err})") from None


def build_segmenter_for(ctx: RunContext, robot: str) -> Any:
    """The scenario's segmenter for ``robot`` (built-in preset, config, or user class)."""
    seg = ctx.scenario.frontend.segmenter
    if isinstance(seg, str) and ":" in seg:
        return _user_object(seg, "segmenter")
    return build_segmenter(seg if isinstance(seg, (str, SegmenterConfig)) else seg, seed=ctx.scenario.seed)


def build_encoder_for(ctx: RunContext, robot: str, world: Any) -> Any:
    """The scenario's semantic encoder (simulated from truth, or a user class).

    Prototypes are shared by all robots (same seed); observation noise is per robot.
    """
    enc = ctx.scenario.frontend.encoder
    if enc == "simulated":
        families = {o.id: o.family for o in world.truth.objects}
        return SimulatedEncoder(ctx.scenario.frontend.semantics, seed=ctx.scenario.seed, families=families, robot=robot)
    if ":" in enc:
        return _user_object(enc, "semantic encoder")
    raise ConfigError(f"frontend.encoder: unknown encoder {enc!r} (valid: simulated, or package.module:Class)")


def _recording_key(ctx: RunContext, cfg: Any) -> str:
    """What a robot's rendered frames depend on: seed, world, every robot (paths may refer to others)."""
    sc = ctx.scenario.model_dump(mode="json")
    return stable_hash(sc["seed"], sc["world"], sc["robots"], cfg.name)


def _frames(ctx: RunContext, world: Any, cfg: Any, trajectory: Any) -> Iterable[Frame]:
    """Rendered frames of one robot (from the run's recording when ``record_frames`` and it matches)."""
    from roman_sim.sim.recording import read_recording, recording_info, write_recording
    from roman_sim.sim.robot import render_trajectory

    sc = ctx.scenario
    rec_dir = ctx.run_dir / "recordings" / cfg.name
    key = _recording_key(ctx, cfg)
    if sc.record_frames and not ctx.fresh:
        try:
            if recording_info(rec_dir).get("extra", {}).get("key") == key:
                return read_recording(rec_dir)
        except RomanSimError:
            pass
    frames = render_trajectory(world, cfg, sc.seed, trajectory)
    if not sc.record_frames:
        return frames
    write_recording(frames, rec_dir, overwrite=True, extra={"scenario": sc.name, "seed": sc.seed, "key": key})
    return read_recording(rec_dir)


def map_robot(ctx: RunContext, world: Any, cfg: Any, path: Any) -> tuple[SegmentMap, KeyframeSet | None]:
    """Render and map one robot along its planned path; its keyframes too when the visual method runs."""
    from roman_sim.sim.robot import trajectory_along

    sc = ctx.scenario
    trajectory = trajectory_along(world, cfg, sc.seed, path)
    stage = f"maps:{cfg.name}"
    ctx.progress.start(stage, len(trajectory[0]))
    mapper = Mapper(sc.mapping, build_segmenter_for(ctx, cfg.name), build_encoder_for(ctx, cfg.name, world), seed=sc.seed)
    extractor = KeyframeExtractor(default_vocabulary(), sc.frontend.keyframes) if sc.uses_visual else None
    for frame in _frames(ctx, world, cfg, trajectory):
        mapper.process(frame)
        if extractor is not None:
            extractor.offer(frame.public())
        ctx.progress.advance(stage)
    ctx.progress.end(stage)
    smap = mapper.finish()
    log.info("robot %s: %d segments%s", cfg.name, len(smap),
             "" if extractor is None else f", {len(extractor.keyframes)} keyframes")
    return smap, None if extractor is None else extractor.keyframe_set()


class MapsStage(Stage[Maps]):
    """Render and map every robot of the scenario."""

    name = "maps"
    inputs = ("world",)

    def applies(self, ctx: RunContext) -> bool:
        return ctx.submaps_dir is None

    def config_parts(self, ctx: RunContext) -> list[Any]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["robots"], sc["frontend"], sc["mapping"], ctx.scenario.uses_visual]

    def run(self, ctx: RunContext, world: WorldOutput | None = None, **_: Any) -> Maps:
        from roman_sim.sim.robot import plan_paths

        assert world is not None, "the maps stage needs the world"
        paths = plan_paths(world.world, ctx.scenario.robots, ctx.scenario.seed)
        maps, keyframes = {}, {}
        for cfg in ctx.scenario.robots:
            maps[cfg.name], kf = map_robot(ctx, world.world, cfg, paths[cfg.name])
            if kf is not None:
                keyframes[cfg.name] = kf
        return Maps(maps, keyframes=keyframes)

    def save(self, out: Maps, ctx: RunContext) -> list[str]:
        files = save_per_robot(ctx, "maps", out.maps, save_segment_map, out.notes)
        if out.keyframes:
            files += save_per_robot(ctx, "keyframes", out.keyframes, save_keyframes, [])
        return files

    def load(self, ctx: RunContext, files: list[str]) -> Maps:
        maps, notes = load_per_robot(ctx, "maps", load_segment_map)
        keyframes = load_per_robot(ctx, "keyframes", load_keyframes)[0] if ctx.scenario.uses_visual else {}
        return Maps(maps, notes, keyframes)
