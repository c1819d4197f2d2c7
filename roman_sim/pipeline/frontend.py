"""Stages world -> maps -> submaps: simulate each robot, map its frames, cut submaps."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

from roman_sim.core.errors import ConfigError, RomanSimError
from roman_sim.mapping.io import load_segment_map, load_submaps, save_segment_map, save_submaps
from roman_sim.mapping.mapper import Mapper, SegmentMap
from roman_sim.mapping.frontend import build_encoder, build_segmenter, encoder_spec
from roman_sim.mapping.submap import build_submaps
from roman_sim.mapping.types import Submap

if TYPE_CHECKING:
    from roman_sim.pipeline.experiment import Experiment

log = logging.getLogger(__name__)


def world_stage(exp: "Experiment") -> None:
    """Generate the world (deterministic in the seed, so it is never cached)."""
    from roman_sim.world import generate

    exp._state["world"] = generate(exp.sc.world.spec(), exp.sc.seed)


def map_files(exp: "Experiment") -> list[Path]:
    return [exp.dir / "maps" / f"{r.name}.npz" for r in exp.sc.robots]


def submap_files(exp: "Experiment") -> list[Path]:
    return [exp.dir / "submaps" / f"{r.name}.npz" for r in exp.sc.robots]


def build_segmenter_for(exp: "Experiment", robot: str) -> Any:
    """The scenario's segmenter for ``robot`` (built-in or user class, with its params)."""
    return build_segmenter(exp.sc.frontend, seed=exp.sc.seed, robot=robot)


def build_encoder_for(exp: "Experiment", robot: str) -> Any:
    """The scenario's semantic encoder for ``robot``.

    Prototypes of the simulated encoder are shared by all robots (same seed); its
    observation noise is per robot. Only a truth-driven encoder gets the families.
    """
    families = None
    if encoder_spec(exp.sc.frontend.encoder).reads_truth:
        families = {o.id: o.family for o in exp._state["world"].truth.objects}
    return build_encoder(exp.sc.frontend, seed=exp.sc.seed, robot=robot, families=families)


def _frames(exp: "Experiment", world: Any, cfg: Any, trajectory: Any) -> Any:
    from roman_sim.sim.recording import read_recording, recording_info, write_recording
    from roman_sim.sim.robot import render_trajectory

    rec_dir = exp.dir / "recordings" / cfg.name
    if exp.sc.record_frames and not exp.fresh:
        try:
            recording_info(rec_dir)
            return read_recording(rec_dir)
        except RomanSimError:
            pass
    frames = render_trajectory(world, cfg, exp.sc.seed, trajectory)
    if not exp.sc.record_frames:
        return frames
    write_recording(frames, rec_dir, overwrite=True, extra={"scenario": exp.sc.name, "seed": exp.sc.seed})
    return read_recording(rec_dir)


def maps_stage(exp: "Experiment") -> None:
    """Simulate and map every robot (paths in order, so relations to earlier robots resolve)."""
    from roman_sim.sim.robot import plan_paths, trajectory_along

    world = exp._state["world"]
    paths = plan_paths(world, exp.sc.robots, exp.sc.seed)
    maps: dict[str, SegmentMap] = {}
    for cfg in exp.sc.robots:
        trajectory = trajectory_along(world, cfg, exp.sc.seed, paths[cfg.name])
        stage = f"maps:{cfg.name}"
        exp.progress.start(stage, len(trajectory[0]))
        mapper = Mapper(exp.sc.mapping, build_segmenter_for(exp, cfg.name), build_encoder_for(exp, cfg.name), seed=exp.sc.seed)
        for frame in _frames(exp, world, cfg, trajectory):
            mapper.process(frame)
            exp.progress.advance(stage)
        maps[cfg.name] = mapper.finish()
        exp.progress.end(stage)
        save_segment_map(exp.dir / "maps" / f"{cfg.name}.npz", maps[cfg.name])
        log.info("robot %s: %d segments", cfg.name, len(maps[cfg.name]))
    exp._state["maps"] = maps


def submaps_stage(exp: "Experiment") -> None:
    """Cut each robot's map into submaps (or load the user's submaps)."""
    out: dict[str, list[Submap]] = {}
    if exp.submaps_dir is not None:
        files = sorted(exp.submaps_dir.glob("*.npz"))
        if not files:
            raise ConfigError(f"--submaps {exp.submaps_dir}: no <robot>.npz submap files there")
        for f in files:
            subs = load_submaps(f)
            for s in subs:
                out.setdefault(s.robot, []).append(s)
    else:
        maps = exp._state["maps"]
        for name, smap in maps.items():
            out[name] = build_submaps(smap, exp.sc.submaps)
    for name, subs in out.items():
        save_submaps(exp.dir / "submaps" / f"{name}.npz", subs)
    exp._state["submaps"] = out


def load_frontend_stage(exp: "Experiment", name: str) -> None:
    """Reload a cached front-end stage's outputs."""
    if name == "maps":
        exp._state["maps"] = {r.name: load_segment_map(exp.dir / "maps" / f"{r.name}.npz") for r in exp.sc.robots}
    elif name == "submaps":
        exp._state["submaps"] = {f.stem: load_submaps(f) for f in sorted((exp.dir / "submaps").glob("*.npz"))}
