"""Mapping one robot: its input opened once, one loop into the sinks, a ``SegmentMap`` graded on its own.

The maps stage runs ``map_one`` per robot, in this process or as a worker task
(``roman_sim.pipeline.stages.maps_job.map_robot_task``). Everything the job reads of the robot
comes from its ``RobotInput`` (``roman_sim.pipeline.stages.maps_input.open_robot``: its frames,
whether rendered, read from the run's recording or read from a TUM RGB-D folder, with the
odometry they carry; its families, looks and world); ``map_source`` feeds the frames to the
mapper and, when a scenario lists the ``visual`` method, to the keyframe extractor. Nothing
here asks what kind of robot it maps.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from roman_sim.align.visual import KeyframeExtractor, default_vocabulary
from roman_sim.core.errors import ConfigError, RomanSimError, StorageError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.sensors import Frame
from roman_sim.evaluation.grader import FrontEndGrader, GraderPart
from roman_sim.evaluation.grades import GradeConfig
from roman_sim.frontend.appearance import SceneLooks
from roman_sim.frontend.components import build_encoder, build_segmenter, encoder_spec
from roman_sim.mapping.io import load_keyframes, load_segment_map, save_keyframes, save_segment_map
from roman_sim.mapping.mapper import Mapper, SegmentMap
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.protocols import Segmenter, SemanticEncoder, reads_truth
from roman_sim.mapping.tracker import Observation
from roman_sim.mapping.types import KeyframeSet
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.plugin_guard import guard_frontend
from roman_sim.pipeline.stages.maps_input import RobotInput, WorldSupply, open_robot
from roman_sim.report.snapshot import FrameSnapshot, load_snapshot, save_snapshot
from roman_sim.runner.checkpoint import Kept

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from roman_sim.pipeline.scenario import ScenarioRobot

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


def map_source(ctx: RunContext, robot: RobotInput, grader: _Grader | None = None) -> MapAndKeyframes:
    """One loop of the robot's frames into the sinks: the mapper (graded by ``grader``) and, when the
    visual method runs, the keyframe extractor. The robot's world serves the ``mapping.whole_surface``
    counterfactual (``roman_sim.frontend.whole_surface``); its looks are the simulated encoder's view
    of the world (``roman_sim.interop.looks``)."""
    sc = ctx.scenario
    name = robot.name
    stage = f"maps:{name}"
    ctx.progress.start(stage, len(robot.frames))
    # plug-ins are guarded: an exception or a wrong return inside them names the plug-in and the frame
    fe = sc.frontend
    encoder = build_encoder_for(ctx, name, robot.families, robot.looks)
    segmenter, encoder = guard_frontend(build_segmenter_for(ctx, name), fe.segmenter.name, encoder, fe.encoder.name)
    if grader is not None:
        grader.use(robot.families)
    reshape: Callable[[Frame, list[Observation]], list[Observation]] | None = None
    if sc.mapping.whole_surface:
        from roman_sim.frontend.whole_surface import whole_surface_for

        reshape = whole_surface_for(robot.world, sc.mapping.voxel, name)
    elif sc.mapping.complete:
        from roman_sim.frontend.surface_completion import surface_completion_for

        reshape = surface_completion_for(
            robot.world, sc.mapping.voxel, sc.mapping.max_depth_m, list(sc.mapping.complete), name
        )
    on_frame = None if grader is None else grader.add
    mapper = Mapper(sc.mapping, segmenter, encoder, seed=sc.seed, on_frame=on_frame, reshape=reshape)
    extractor = KeyframeExtractor(default_vocabulary(), sc.frontend.keyframes) if sc.uses_visual else None
    for frame in robot.frames.frames():
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


def map_one(ctx: RunContext, world: WorldSupply, cfg: ScenarioRobot) -> RobotMapping:
    """One robot, opened once (``open_robot``: its frames, families, looks and world), mapped and graded on its own."""
    sc = ctx.scenario
    robot = open_robot(ctx, cfg, world)
    grader = _Grader(sc.frontend.semantics.group_of, sc.seed, cfg.name, sc.mapping.max_depth_m)
    smap, kf = map_source(ctx, robot, grader)
    snap = frame_snapshot(ctx, robot, smap) if cfg.name == sc.robots[0].name else None
    return smap, kf, grader.part(), snap


def busiest_frame(smap: SegmentMap) -> int:
    """The frame in sight of the most segments (seen first at or before it, last at or after it); the first of ties."""
    if not len(smap.times):
        raise StorageError(f"robot {smap.robot}: no frames")
    first = np.array([s.first_seen for s in smap.segments])
    last = np.array([s.last_seen for s in smap.segments])
    seen = [int(np.sum((first <= t) & (last >= t))) for t in smap.times]
    return int(np.argmax(seen))


def frame_snapshot(ctx: RunContext, robot: RobotInput, smap: SegmentMap) -> FrameSnapshot | None:
    """The report's front-end snapshot: the robot's busiest frame (``busiest_frame``) with RGB, and the masks
    the scenario's segmenter cuts from it (from the frame without truth unless it reads truth).

    None (and a warning) when it cannot be taken (no OpenGL context, no colour image, ...).
    """
    sc = ctx.scenario
    try:
        i = busiest_frame(smap)
        frame = next(iter(robot.rgb.frames([i])))
        segmenter = build_segmenter_for(ctx, robot.name)
        masks = segmenter.segment(frame if reads_truth(segmenter) else frame.public())
        seg = sc.frontend.segmenter
        return FrameSnapshot.of(frame, [m.pixels for m in masks], seg if isinstance(seg, str) else "configured")
    except (RomanSimError, RuntimeError, ImportError, StopIteration) as err:
        log.warning("robot %s: no front-end snapshot (%s)", robot.name, err)
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
