"""Mapping one robot: its frame source, one loop into the sinks, a ``SegmentMap`` graded on its own.

The maps stage runs ``map_one`` per robot, in this process or as a worker task
(``roman_sim.pipeline.stages.maps_job.map_robot_task``). The robot's frames come from one
``FrameSource`` (``robot_source``: rendered, read from the run's recording, or read from a
TUM RGB-D folder); ``map_source`` feeds them to the mapper and, when a scenario lists the
``visual`` method, to the keyframe extractor, whatever the source.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from roman_sim.align.visual import KeyframeExtractor, default_vocabulary
from roman_sim.align.visual.keyframes import keyframe_mask
from roman_sim.core.config import stable_hash
from roman_sim.core.errors import ConfigError, RomanSimError, StorageError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.sensors import Frame, FrameSource
from roman_sim.evaluation.grader import FrontEndGrader, GraderPart
from roman_sim.evaluation.grades import GradeConfig
from roman_sim.frontend.appearance import SceneLooks
from roman_sim.frontend.components import build_encoder, build_segmenter, encoder_spec
from roman_sim.mapping.io import load_keyframes, load_segment_map, save_keyframes, save_segment_map
from roman_sim.mapping.mapper import Mapper, SegmentMap
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.protocols import Segmenter, SemanticEncoder, reads_truth
from roman_sim.mapping.types import KeyframeSet
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.plugin_guard import guard_frontend, is_plugin
from roman_sim.report.snapshot import FrameSnapshot, load_snapshot, save_snapshot
from roman_sim.runner.checkpoint import Kept

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from roman_sim.pipeline.scenario import ScenarioRobot
    from roman_sim.sim.robot import DrivenRun
    from roman_sim.sim.source import SimulatedRobot
    from roman_sim.world import World

log = logging.getLogger(__name__)
MapAndKeyframes = tuple[SegmentMap, KeyframeSet | None]
#: What mapping one robot gives: its map, its keyframes (visual method), its share of the front-end grades
#: and, for the scenario's first robot, the report's front-end snapshot.
RobotMapping = tuple[SegmentMap, KeyframeSet | None, GraderPart | None, FrameSnapshot | None]


def build_segmenter_for(ctx: RunContext, robot: str) -> Segmenter:
    """The scenario's segmenter for ``robot`` (built-in or user class, with its params)."""
    return build_segmenter(ctx.scenario.frontend, seed=ctx.scenario.seed, robot=robot)


def build_encoder_for(
    ctx: RunContext, robot: str, families: dict[int, str] | None, looks: SceneLooks | None = None
) -> SemanticEncoder:
    """The scenario's semantic encoder for ``robot``; only a truth-driven one gets ``families``.

    ``families`` (object id -> family: the world's, or a sequence's object table) feeds the
    simulated encoder. Its prototypes are shared by all robots (same seed); its observation
    noise is per robot. ``looks`` (``roman_sim.interop.looks.robot_looks``) tells it how the
    world draws each object and the robot's light.
    """
    fe = ctx.scenario.frontend
    if encoder_spec(fe.encoder).reads_truth and families is None:
        raise ConfigError(
            f"robot {robot}: the {fe.encoder.name} encoder needs the objects' families (no world, "
            "no object table); use an image encoder (image, clip, dinov2 or package.module:Class)"
        )
    return build_encoder(fe, seed=ctx.scenario.seed, robot=robot, families=families, looks=looks)


def _recording_key(ctx: RunContext, name: str) -> str:
    """What a robot's rendered frames depend on: seed, world, every robot (paths may refer to others)."""
    sc = ctx.scenario.model_dump(mode="json")
    return stable_hash(sc["seed"], sc["world"], sc["robots"], name)


def robot_source(ctx: RunContext, world: World | None, cfg: ScenarioRobot) -> FrameSource:
    """The robot's frames as the maps stage reads them (``roman_sim.sim.source.robot_sources``).

    A robot with a ``source`` is its TUM RGB-D sequence; a simulated robot renders RGB only
    where something reads it (``_rgb_frames``) and, with ``record_frames``, is read through
    its recording (``_recorded``).
    """
    from roman_sim.pipeline.stages.maps_sources import open_sequence
    from roman_sim.sim.source import SimulatedRobot, robot_sources

    sc = ctx.scenario
    source = robot_sources(world, sc.robots, sc.seed, [cfg.name], open_recorded=lambda r: open_sequence(r, sc.seed))[0]
    if not isinstance(source, SimulatedRobot):
        return source
    if sc.record_frames:
        return _recorded(ctx, source)
    flags = _rgb_frames(ctx, source.run)
    return source if flags is None else source.rgb_at(flags)


def _recorded(ctx: RunContext, source: SimulatedRobot) -> FrameSource:
    """The run's recording of ``source`` (``recordings/<robot>``): read back when its key matches, else
    rendered into it (every frame with RGB) first."""
    from roman_sim.sim.recording import Recording, RecordingOrigin, recording_info, write_recording

    sc = ctx.scenario
    rec_dir = ctx.run_dir / "recordings" / source.name
    key = _recording_key(ctx, source.name)
    if not ctx.fresh:
        try:
            origin = recording_info(rec_dir).extra
            if origin is not None and origin.key == key:
                return Recording(rec_dir)
        except RomanSimError:
            pass
    write_recording(source.frames(), rec_dir, overwrite=True, origin=RecordingOrigin(sc.name, sc.seed, key))
    return Recording(rec_dir)


def _rgb_frames(ctx: RunContext, trajectory: DrivenRun) -> NDArray[np.bool_] | list[bool] | None:
    """Frames whose RGB is read (None: all): a plug-in or RGB front end reads all, the visual method keyframes."""
    sc = ctx.scenario
    fe = sc.frontend
    if is_plugin(fe.segmenter.name) or is_plugin(fe.encoder.name) or fe.needs_rgb:
        return None
    if not sc.uses_visual:
        return [False] * len(trajectory.t)
    return keyframe_mask(trajectory.t, trajectory.T_odom_body, fe.keyframes)


def robot_families(world: World | None, cfg: ScenarioRobot) -> dict[int, str] | None:
    """Object id -> family of the robot's objects: the world's, or its sequence's object table (None without one)."""
    from roman_sim.pipeline.stages.maps_sources import sequence_families

    if cfg.source is not None:
        return sequence_families(cfg.source)
    if world is None:
        raise ConfigError(f"robot {cfg.name}: a simulated robot needs the world")
    return {o.id: o.family for o in world.truth.objects}


def robot_looks_for(world: World | None, cfg: ScenarioRobot, seed: int) -> SceneLooks | None:
    """What the robot's simulated encoder knows of how its objects are drawn: the world's looks, or
    those its sequence's object table carries (None without either)."""
    from roman_sim.interop.looks import robot_looks, sequence_looks
    from roman_sim.pipeline.stages.maps_sources import object_table_path

    if cfg.source is not None:
        table = object_table_path(cfg.source)
        return None if table is None else sequence_looks(table, cfg.name)
    return robot_looks(world, cfg.name, cfg.lighting, seed)


def map_source(
    ctx: RunContext,
    source: FrameSource,
    families: dict[int, str] | None,
    grader: _Grader | None = None,
    world: World | None = None,
    looks: SceneLooks | None = None,
) -> MapAndKeyframes:
    """One loop of ``source``'s frames into the sinks: the mapper (graded by ``grader``) and, when the
    visual method runs, the keyframe extractor. ``world`` serves the ``mapping.whole_surface``
    counterfactual (``roman_sim.frontend.whole_surface``); ``looks`` is the simulated encoder's view
    of the world (``roman_sim.interop.looks``)."""
    sc = ctx.scenario
    name = source.name
    stage = f"maps:{name}"
    ctx.progress.start(stage, len(source))
    # plug-ins are guarded: an exception or a wrong return inside them names the plug-in and the frame
    fe = sc.frontend
    encoder = build_encoder_for(ctx, name, families, looks)
    segmenter, encoder = guard_frontend(build_segmenter_for(ctx, name), fe.segmenter.name, encoder, fe.encoder.name)
    if grader is not None:
        grader.use(families)
    reshape = None
    if sc.mapping.whole_surface:
        from roman_sim.frontend.whole_surface import whole_surface_for

        reshape = whole_surface_for(world, sc.mapping.voxel, name)
    on_frame = None if grader is None else grader.add
    mapper = Mapper(sc.mapping, segmenter, encoder, seed=sc.seed, on_frame=on_frame, reshape=reshape)
    extractor = KeyframeExtractor(default_vocabulary(), sc.frontend.keyframes) if sc.uses_visual else None
    for frame in source.frames():
        mapper.process(frame)
        if extractor is not None:
            extractor.offer(frame.public())
        ctx.progress.advance(stage)
    ctx.progress.end(stage)
    smap = mapper.finish()
    log.info(
        "robot %s: %d segments%s",
        name,
        len(smap),
        "" if extractor is None else f", {len(extractor.keyframes)} keyframes",
    )
    return smap, None if extractor is None else extractor.keyframe_set()


class _Grader:
    """Grades every frame that has instance truth (a real sequence may have none) against it.

    The families of the robot being mapped (the world's, or a sequence's object table)
    label the descriptors; nothing here is visible to the segmenter or the encoder.
    """

    def __init__(
        self, group_of: Callable[[str], str], seed: int, robot: str | None = None, max_depth_m: float = 7.5
    ) -> None:
        self.inner = FrontEndGrader({}, group_of, GradeConfig(max_depth_m=max_depth_m), seed=seed, stream=robot)

    def use(self, families: dict[int, str] | None) -> FrontEndGrader:
        self.inner.families.update(families or {})
        return self.inner

    def add(self, frame: Frame, masks: list[Mask], observed: list[tuple[int, NDArray[np.float32] | None]]) -> None:
        if frame.truth is not None and frame.truth.object_ids is not None:
            self.inner.add(frame, masks, observed)

    def part(self) -> GraderPart | None:
        """This robot's share of the grades (None when no frame had instance truth)."""
        return self.inner.part() if self.inner.seg.frames else None


def map_one(ctx: RunContext, world: World | None, cfg: ScenarioRobot) -> RobotMapping:
    """One robot, simulated in ``world`` or read from its sequence (``cfg.source``), graded on its own."""
    sc = ctx.scenario
    grader = _Grader(sc.frontend.semantics.group_of, sc.seed, cfg.name, sc.mapping.max_depth_m)
    looks = robot_looks_for(world, cfg, sc.seed) if encoder_spec(sc.frontend.encoder).reads_truth else None
    source = robot_source(ctx, world, cfg)
    own_world = None if cfg.source is not None else world
    smap, kf = map_source(ctx, source, robot_families(world, cfg), grader, own_world, looks)
    snap = frame_snapshot(ctx, world, cfg, smap) if cfg.name == sc.robots[0].name else None
    return smap, kf, grader.part(), snap


def busiest_frame(smap: SegmentMap) -> int:
    """The frame in sight of the most segments (seen first at or before it, last at or after it); the first of ties."""
    if not len(smap.times):
        raise StorageError(f"robot {smap.robot}: no frames")
    first = np.array([s.first_seen for s in smap.segments])
    last = np.array([s.last_seen for s in smap.segments])
    seen = [int(np.sum((first <= t) & (last >= t))) for t in smap.times]
    return int(np.argmax(seen))


def frame_snapshot(ctx: RunContext, world: World | None, cfg: ScenarioRobot, smap: SegmentMap) -> FrameSnapshot | None:
    """The report's front-end snapshot: the robot's busiest frame (``busiest_frame``) with RGB, and the masks
    the scenario's segmenter cuts from it (from the frame without truth unless it reads truth).

    None (and a warning) when it cannot be taken (no OpenGL context, no colour image, ...).
    """
    from roman_sim.pipeline.stages.maps_sources import open_sequence
    from roman_sim.sim.source import robot_sources

    sc = ctx.scenario
    try:
        i = busiest_frame(smap)
        source = robot_sources(
            world, sc.robots, sc.seed, [cfg.name], rgb=True, open_recorded=lambda r: open_sequence(r, sc.seed)
        )[0]
        frame = next(iter(source.frames([i])))
        segmenter = build_segmenter_for(ctx, cfg.name)
        masks = segmenter.segment(frame if reads_truth(segmenter) else frame.public())
        seg = sc.frontend.segmenter
        return FrameSnapshot.of(frame, [m.pixels for m in masks], seg if isinstance(seg, str) else "configured")
    except (RomanSimError, RuntimeError, ImportError, StopIteration) as err:
        log.warning("robot %s: no front-end snapshot (%s)", cfg.name, err)
        return None


class RobotMappingCodec:
    """Checkpoint codec of a robot's mapping (``TaskCodec``): ``<stem>.map.npz``, ``.keyframes.npz``, ``.grades.npz``,
    ``.snapshot.npz``.

    The map, keyframes and snapshot go through the same writers as the maps stage's own files, the
    grade part through its arrays, so what is read back is what the stage saves.
    """

    def write(self, value: RobotMapping, stem: Path) -> Kept:
        """Write the map, the keyframes, the grade part and the snapshot that exist."""
        from roman_sim.core.atomic import write_arrays

        smap, kf, part, snap = value
        files = [_part(stem, "map")]
        save_segment_map(files[0], smap)
        if kf is not None:
            files.append(_part(stem, "keyframes"))
            save_keyframes(files[-1], kf)
        if part is not None:
            files.append(_part(stem, "grades"))
            write_arrays(files[-1], part.arrays())
        if snap is not None:
            files.append(_part(stem, "snapshot"))
            save_snapshot(files[-1], snap)
        return Kept({"keyframes": kf is not None, "grades": part is not None, "snapshot": snap is not None}, files)

    def read(self, data: JSON, stem: Path) -> RobotMapping:
        """The map, keyframes and grade part ``write`` kept."""
        if not isinstance(data, dict):
            raise StorageError(f"{stem}: malformed mapping checkpoint")
        part = None
        if data.get("grades"):
            with np.load(_part(stem, "grades"), allow_pickle=False) as z:
                part = GraderPart.from_arrays(z, str(_part(stem, "grades")))
        kf = load_keyframes(_part(stem, "keyframes")) if data.get("keyframes") else None
        snap = load_snapshot(_part(stem, "snapshot")) if data.get("snapshot") else None
        return load_segment_map(_part(stem, "map")), kf, part, snap


def _part(stem: Path, name: str) -> Path:
    return stem.with_name(f"{stem.name}.{name}.npz")
