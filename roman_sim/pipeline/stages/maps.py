"""Stage ``maps``: simulate every robot and map its frames into a ``SegmentMap``.

Robots are planned together (a path may be defined relative to an earlier robot's), then
rendered and mapped one by one; each robot's map is written as soon as it is finished.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from roman_sim.core.atomic import write_json
from roman_sim.core.config import stable_hash
from roman_sim.core.errors import RomanSimError, StorageError
from roman_sim.evaluation.frontend_grader import FrontEndGrader
from roman_sim.evaluation.frontend_grades import FrontEndGrades, plot_frontend_grades
from roman_sim.mapping.frontend import build_encoder, build_segmenter, encoder_spec
from roman_sim.mapping.io import load_segment_map, save_segment_map
from roman_sim.mapping.mapper import Mapper, SegmentMap
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.notes import load_per_robot, save_per_robot
from roman_sim.pipeline.stages.world import WorldOutput
from roman_sim.sensors import Frame

log = logging.getLogger(__name__)

FRONTEND_JSON = "maps/frontend.json"
FRONTEND_PNG = "plots/frontend.png"


@dataclass
class Maps:
    """Each robot's segment map (robot name -> map, in scenario order), the front end's grades and notes.

    ``frontend`` grades whatever segmenter and encoder ran, against the rendered truth, over
    every robot's frames (None when the frames carry no truth); ``written`` lists the plot.
    """

    maps: dict[str, SegmentMap]
    notes: list[str] = field(default_factory=list)
    frontend: FrontEndGrades | None = None
    written: list[str] = field(default_factory=list)


def build_segmenter_for(ctx: RunContext, robot: str) -> Any:
    """The scenario's segmenter for ``robot`` (built-in or user class, with its params)."""
    return build_segmenter(ctx.scenario.frontend, seed=ctx.scenario.seed, robot=robot)


def build_encoder_for(ctx: RunContext, robot: str, world: Any) -> Any:
    """The scenario's semantic encoder for ``robot``; only a truth-driven one gets the families.

    The simulated encoder's prototypes are shared by all robots (same seed); its
    observation noise is per robot.
    """
    fe = ctx.scenario.frontend
    families = {o.id: o.family for o in world.truth.objects} if encoder_spec(fe.encoder).reads_truth else None
    return build_encoder(fe, seed=ctx.scenario.seed, robot=robot, families=families)


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


def map_robot(ctx: RunContext, world: Any, cfg: Any, path: Any, grader: FrontEndGrader | None = None) -> SegmentMap:
    """Render and map one robot along its planned path (each frame graded by ``grader``)."""
    from roman_sim.sim.robot import trajectory_along

    sc = ctx.scenario
    trajectory = trajectory_along(world, cfg, sc.seed, path)
    stage = f"maps:{cfg.name}"
    ctx.progress.start(stage, len(trajectory[0]))
    mapper = Mapper(sc.mapping, build_segmenter_for(ctx, cfg.name), build_encoder_for(ctx, cfg.name, world),
                    seed=sc.seed, on_frame=None if grader is None else grader.add)
    for frame in _frames(ctx, world, cfg, trajectory):
        mapper.process(frame)
        ctx.progress.advance(stage)
    ctx.progress.end(stage)
    smap = mapper.finish()
    log.info("robot %s: %d segments", cfg.name, len(smap))
    return smap


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
        sc = ctx.scenario
        paths = plan_paths(world.world, sc.robots, sc.seed)
        families = {o.id: o.family for o in world.world.truth.objects}
        grader = FrontEndGrader(families, sc.frontend.semantics.group_of, seed=sc.seed)
        notes = _rgb_notes(ctx)
        maps = {}
        for cfg in sc.robots:
            maps[cfg.name] = map_robot(ctx, world.world, cfg, paths[cfg.name], grader)
        enc = sc.frontend.encoder.name
        return Maps(maps, notes, grader.result(sc.frontend.segmenter.name, enc))

    def save(self, out: Maps, ctx: RunContext) -> list[str]:
        files = save_per_robot(ctx, "maps", out.maps, save_segment_map, out.notes)
        if out.frontend is None:
            return files
        write_json(ctx.run_dir / FRONTEND_JSON, out.frontend.to_json())
        plot_frontend_grades(out.frontend, ctx.run_dir / FRONTEND_PNG)
        return [*files, FRONTEND_JSON, FRONTEND_PNG]

    def load(self, ctx: RunContext, files: list[str]) -> Maps:
        maps, notes = load_per_robot(ctx, "maps", load_segment_map)
        grades = None
        if FRONTEND_JSON in files:
            path = ctx.run_dir / FRONTEND_JSON
            try:
                grades = FrontEndGrades.from_json(json.loads(path.read_text(encoding="utf-8")))
            except (OSError, ValueError) as err:
                raise StorageError(f"{path}: unreadable front-end grades ({type(err).__name__})") from None
        return Maps(maps, notes, grades, [f for f in files if f.endswith(".png")])


def _rgb_notes(ctx: RunContext) -> list[str]:
    """A note (and a warning) for each robot whose user segmenter or encoder will get no RGB."""
    fe = ctx.scenario.frontend
    entries = (("segmenter", fe.segmenter), ("encoder", fe.encoder))
    users = [f"{kind} {e.name!r}" for kind, e in entries if ":" in e.name]
    notes = []
    for r in ctx.scenario.robots:
        if users and not r.render_rgb:
            notes.append(f"robot {r.name} renders no RGB (render_rgb: false): the user {' and '.join(users)} "
                         "got rgb=None")
            log.warning(notes[-1])
    return notes
