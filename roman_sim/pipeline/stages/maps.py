"""Stage ``maps``: simulate (or read) every robot and map its frames into a ``SegmentMap``.

Simulated robots are planned together (a path may be defined relative to an earlier
robot's), then rendered and mapped one by one; a robot with a ``source`` is read from its
TUM RGB-D folder instead (``roman_sim.pipeline.sources``) and mapped the same way.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from roman_sim.core.config import stable_hash
from roman_sim.core.errors import ConfigError, RomanSimError
from roman_sim.core.plugin_guard import guard_frontend
from roman_sim.core.plugins import instantiate_plugin
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


def build_segmenter_for(ctx: RunContext, robot: str) -> Any:
    """The scenario's segmenter for ``robot`` (built-in preset, config, or user class)."""
    seg = ctx.scenario.frontend.segmenter
    if isinstance(seg, str) and ":" in seg:
        return instantiate_plugin(seg, "segmenter")
    return build_segmenter(seg if isinstance(seg, (str, SegmenterConfig)) else seg, seed=ctx.scenario.seed)


def build_encoder_for(ctx: RunContext, robot: str, families: dict[int, str] | None) -> Any:
    """The scenario's semantic encoder (simulated from truth, or a user class).

    ``families`` (object id -> family: the world's, or a sequence's object table) feeds the
    simulated encoder. Prototypes are shared by all robots (same seed); observation noise is
    per robot.
    """
    enc = ctx.scenario.frontend.encoder
    if enc == "simulated":
        if families is None:
            raise ConfigError(f"robot {robot}: the simulated encoder needs the objects' families (no world, "
                              "no object table); use an image encoder package.module:Class")
        return SimulatedEncoder(ctx.scenario.frontend.semantics, seed=ctx.scenario.seed, families=families, robot=robot)
    if ":" in enc:
        return instantiate_plugin(enc, "encoder")
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


def _map_frames(ctx: RunContext, name: str, frames: Iterable[Frame], n: int, families: dict[int, str] | None
                ) -> SegmentMap:
    sc = ctx.scenario
    stage = f"maps:{name}"
    ctx.progress.start(stage, n)
    # plug-ins are guarded: an exception or a wrong return inside them names the plug-in and the frame
    segmenter, encoder = guard_frontend(build_segmenter_for(ctx, name), sc.frontend.segmenter,
                                        build_encoder_for(ctx, name, families), sc.frontend.encoder)
    mapper = Mapper(sc.mapping, segmenter, encoder, seed=sc.seed)
    for frame in frames:
        mapper.process(frame)
        ctx.progress.advance(stage)
    ctx.progress.end(stage)
    smap = mapper.finish()
    log.info("robot %s: %d segments", name, len(smap))
    return smap


def map_robot(ctx: RunContext, world: Any, cfg: Any, path: Any) -> SegmentMap:
    """Render and map one robot along its planned path."""
    from roman_sim.sim.robot import trajectory_along

    trajectory = trajectory_along(world, cfg, ctx.scenario.seed, path)
    families = {o.id: o.family for o in world.truth.objects}
    return _map_frames(ctx, cfg.name, _frames(ctx, world, cfg, trajectory), len(trajectory[0]), families)


def map_sequence(ctx: RunContext, cfg: Any) -> SegmentMap:
    """Read and map one robot from its TUM RGB-D folder (``cfg.source``)."""
    from roman_sim.pipeline.sources import open_sequence, sequence_families

    seq = open_sequence(cfg, ctx.scenario.seed)
    return _map_frames(ctx, cfg.name, seq.frames(), len(seq), sequence_families(cfg.source))


def map_one(ctx: RunContext, world: Any, cfg: Any, path: Any) -> SegmentMap:
    """One robot's map: read from its sequence (``cfg.source``) or simulated along ``path``."""
    return map_sequence(ctx, cfg) if cfg.source is not None else map_robot(ctx, world, cfg, path)


def map_robots(ctx: RunContext, world: Any, paths: dict[str, Any]) -> dict[str, SegmentMap]:
    """Every robot's map, one ``map_one`` task per robot on the run's executor (scenario order).

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
    args = [(sc_json, r.name, paths.get(r.name), str(ctx.run_dir), world if local else None) for r in todo]
    fn = (lambda sc, name, path, d, w: map_one(ctx, w, _robot(ctx, name), path)) if local else map_robot_task
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
        from roman_sim.pipeline.sources import fingerprint

        sc = ctx.scenario.model_dump(mode="json")
        sequences = {r.name: fingerprint(r.source) for r in ctx.scenario.robots if r.source is not None}
        return [sc["robots"], sc["frontend"], sc["mapping"], *([sequences] if sequences else [])]

    def run(self, ctx: RunContext, world: WorldOutput | None = None, **_: Any) -> Maps:
        from roman_sim.sim.robot import plan_paths

        simulated = ctx.scenario.simulated_robots()
        assert world is not None or not simulated, "the maps stage needs the world for simulated robots"
        paths = plan_paths(world.world, simulated, ctx.scenario.seed) if world is not None and simulated else {}
        return Maps(map_robots(ctx, None if world is None else world.world, paths))

    def save(self, out: Maps, ctx: RunContext) -> list[str]:
        return save_per_robot(ctx, "maps", out.maps, save_segment_map, out.notes)

    def load(self, ctx: RunContext, files: list[str]) -> Maps:
        return Maps(*load_per_robot(ctx, "maps", load_segment_map))
