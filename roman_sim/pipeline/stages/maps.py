"""Stage ``maps``: simulate every robot and map its frames into a ``SegmentMap``.

Robots are planned together (a path may be defined relative to an earlier robot's), then
rendered and mapped one by one; each robot's map is written as soon as it is finished.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from roman_sim.core.config import stable_hash
from roman_sim.core.errors import ConfigError, RomanSimError
from roman_sim.core.registry import import_object
from roman_sim.mapping.io import load_segment_map, save_segment_map
from roman_sim.mapping.mapper import Mapper, SegmentMap
from roman_sim.mapping.segmenter import SegmenterConfig, build_segmenter
from roman_sim.mapping.semantics import SimulatedEncoder
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.notes import load_per_robot, save_per_robot
from roman_sim.pipeline.stages.world import WorldOutput
from roman_sim.sensors import Frame

log = logging.getLogger(__name__)

@dataclass
class Maps:
    """Each robot's segment map (robot name -> map, in scenario order) and the stage's notes."""

    maps: dict[str, SegmentMap]
    notes: list[str] = field(default_factory=list)


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


def map_robot(ctx: RunContext, world: Any, cfg: Any, path: Any) -> SegmentMap:
    """Render and map one robot along its planned path."""
    from roman_sim.sim.robot import trajectory_along

    sc = ctx.scenario
    trajectory = trajectory_along(world, cfg, sc.seed, path)
    stage = f"maps:{cfg.name}"
    ctx.progress.start(stage, len(trajectory[0]))
    mapper = Mapper(sc.mapping, build_segmenter_for(ctx, cfg.name), build_encoder_for(ctx, cfg.name, world), seed=sc.seed)
    for frame in _frames(ctx, world, cfg, trajectory):
        mapper.process(frame)
        ctx.progress.advance(stage)
    ctx.progress.end(stage)
    smap = mapper.finish()
    log.info("robot %s: %d segments", cfg.name, len(smap))
    return smap


def map_robots(ctx: RunContext, world: Any, paths: dict[str, Any]) -> dict[str, SegmentMap]:
    """Every robot's map, one ``map_robot`` task per robot on the run's executor (scenario order).

    Each finished robot's map is written to ``maps/<robot>.npz`` at once and checkpointed,
    so an interrupted run maps only the robots that did not finish. What is returned is
    the map as written and read back, so fresh and resumed robots give the same bytes.
    """
    from roman_sim.pipeline.checkpoint import Checkpoint
    from roman_sim.pipeline.tasks import map_robot_task

    ex = ctx.tasks()
    done = Checkpoint(ctx.run_dir, "maps", None if ctx.fresh else ctx.stage_key)
    files = {r.name: ctx.run_dir / "maps" / f"{r.name}.npz" for r in ctx.scenario.robots}
    maps: dict[str, SegmentMap] = {}
    for name, f in files.items():
        rec = done.get(name)
        if rec is not None and f.is_file() and rec.get("sha256") == _sha256(f):
            maps[name] = load_segment_map(f)
            log.info("robot %s: reusing the map of an interrupted run", name)
    todo = [r for r in ctx.scenario.robots if r.name not in maps]
    sc_json = ctx.scenario.model_dump_json()
    local = ex.kind == "serial"
    args = [(sc_json, r.name, paths[r.name], str(ctx.run_dir), world if local else None) for r in todo]
    fn = (lambda sc, name, path, d, w: map_robot(ctx, w, _robot(ctx, name), path)) if local \
        else map_robot_task
    ctx.progress.start("maps:robots", len(files))
    ctx.progress.advance("maps:robots", len(maps))
    for i, smap in ex.run_tasks(fn, args, [f"mapping robot {r.name}" for r in todo]):
        name = todo[i].name
        save_segment_map(files[name], smap)
        done.put(name, {"sha256": _sha256(files[name])})
        maps[name] = load_segment_map(files[name])
        ctx.progress.advance("maps:robots")
    ctx.progress.end("maps:robots")
    return {name: maps[name] for name in files}


def _robot(ctx: RunContext, name: str) -> Any:
    return next(r for r in ctx.scenario.robots if r.name == name)


def _sha256(path: Any) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


class MapsStage(Stage[Maps]):
    """Render and map every robot of the scenario."""

    name = "maps"
    inputs = ("world",)

    def applies(self, ctx: RunContext) -> bool:
        return ctx.submaps_dir is None

    def config_parts(self, ctx: RunContext) -> list[Any]:
        sc = ctx.scenario.model_dump(mode="json")
        return [sc["robots"], sc["frontend"], sc["mapping"]]

    def run(self, ctx: RunContext, world: WorldOutput | None = None, **_: Any) -> Maps:
        from roman_sim.sim.robot import plan_paths

        assert world is not None, "the maps stage needs the world"
        paths = plan_paths(world.world, ctx.scenario.robots, ctx.scenario.seed)
        return Maps(map_robots(ctx, world.world, paths))

    def save(self, out: Maps, ctx: RunContext) -> list[str]:
        return save_per_robot(ctx, "maps", out.maps, save_segment_map, out.notes)

    def load(self, ctx: RunContext, files: list[str]) -> Maps:
        return Maps(*load_per_robot(ctx, "maps", load_segment_map))
