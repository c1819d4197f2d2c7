"""Stage ``maps``: simulate (or read) every robot and map its frames into a ``SegmentMap``.

Each robot is one task (``roman_sim.pipeline.stages.maps_robot.map_one``): its frame source
(``roman_sim.sim.source.robot_sources``: simulated robots are planned together, since a path
may be defined relative to an earlier robot's; a robot with a ``source`` is read from its
TUM RGB-D folder, ``roman_sim.pipeline.stages.maps_sources``) mapped in one loop.
When a scenario lists the ``visual`` method, the same frames also give each robot's visual
keyframes (ORB features with depth and BoW vectors, ``frontend.keyframes``), saved as
``keyframes/<robot>.npz`` with poses in the robot's odometry frame.

``run`` hands one task per robot to its ``TaskRunner`` (checkpointed per robot) and writes
nothing; ``save`` writes ``maps/``, ``keyframes/``, ``maps/frontend.json`` (the front end's
grades) and ``maps/snapshot.npz`` (the first robot's busiest camera frame with its masks);
the report stage draws both. With ``record_frames``, the rendered frames are a cache, not an
output of the stage: the mapping task (``roman_sim.pipeline.stages.maps_robot``) streams them
into ``recordings/<robot>/`` as it renders (holding a robot's frames in memory until
``save`` would cost gigabytes at paper scale) and reads them back, under a key of what they
depend on (seed, world, robots), so a later run with other mapping settings maps them
again without rendering. They are not in the manifest and survive a stage's completion,
unlike the checkpoints under ``partial/``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import read_record, write_record
from roman_sim.evaluation.grader import FrontEndGrader, GraderPart
from roman_sim.evaluation.grades import FrontEndGrades
from roman_sim.mapping.io import load_keyframes, load_segment_map, save_keyframes, save_segment_map
from roman_sim.mapping.mapper import SegmentMap
from roman_sim.mapping.types import KeyframeSet
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stagefiles import load_per_robot, save_per_robot
from roman_sim.pipeline.stages.base import Stage, Timings
from roman_sim.pipeline.stages.maps_robot import RobotMapping, RobotMappingCodec, map_one
from roman_sim.pipeline.stages.world import WorldOutput
from roman_sim.report.snapshot import FrameSnapshot, load_snapshot, save_snapshot
from roman_sim.runner.taskrunner import TaskRunner

if TYPE_CHECKING:
    from roman_sim.world import World

log = logging.getLogger(__name__)


FRONTEND_JSON = "maps/frontend.json"
SNAPSHOT_NPZ = "maps/snapshot.npz"


@dataclass
class Maps:
    """Each robot's segment map (robot name -> map, in scenario order), the stage's notes, the
    front end's grades and, when the visual method runs, each robot's keyframes (poses in its
    odometry frame).

    ``frontend`` grades whatever segmenter and encoder ran against the frames' instance truth,
    over every robot (None when no frame has instance truth). ``snapshot`` is the first robot's
    busiest camera frame with its segmenter's masks (None when it could not be taken).
    """

    maps: dict[str, SegmentMap]
    notes: list[str] = field(default_factory=list)
    keyframes: dict[str, KeyframeSet] = field(default_factory=dict)
    frontend: FrontEndGrades | None = None
    snapshot: FrameSnapshot | None = None
    timings: Timings = field(default_factory=dict, repr=False, compare=False)


@dataclass(frozen=True)
class MapsInputs:
    """The world (None when every robot is read from a sequence)."""

    world: WorldOutput | None = None


def map_robots(
    ctx: RunContext, world: World | None, tasks: TaskRunner
) -> tuple[dict[str, SegmentMap], dict[str, KeyframeSet], list[GraderPart], FrameSnapshot | None]:
    """Every robot, one ``map_one`` task per robot through ``tasks`` (scenario order).

    ``tasks`` checkpoints each finished robot (its map, keyframes and share of the front-end
    grades), so an interrupted run maps only the robots that did not finish, and hands back
    what it kept, so fresh and resumed robots give the same bytes. Returns the maps, the
    keyframes (robots that have them) and the grade parts (robots with instance truth), in
    scenario order, and the first robot's snapshot.
    """
    from roman_sim.pipeline.stages.maps_job import map_robot_task
    from roman_sim.world import PickledWorld

    robots = ctx.scenario.robots
    names = [r.name for r in robots]
    sc_json = ctx.scenario.model_dump_json()
    local = tasks.in_process
    # A local pool's workers get the world pickled (a second to send and load against seconds
    # to generate); Dask workers, possibly on other machines, regenerate it from the scenario.
    shipped: World | PickledWorld | None = world if local else None
    if not local and world is not None and tasks.kind == "local":
        shipped = PickledWorld.of(world)
    args = [(sc_json, r.name, str(ctx.run_dir), shipped) for r in robots]

    def here(sc: str, name: str, run_dir: str, w: World | None) -> RobotMapping:
        return map_one(ctx, lambda: w, next(r for r in robots if r.name == name))

    fn = here if local else map_robot_task
    results: dict[str, RobotMapping] = {}
    ctx.progress.start("maps:robots", len(names))
    for i, res in tasks.run(fn, args, [f"mapping robot {n}" for n in names], names, RobotMappingCodec()):
        results[names[i]] = res
        ctx.progress.advance("maps:robots")
    ctx.progress.end("maps:robots")
    maps = {n: results[n][0] for n in names}
    keyframes = {n: kf for n in names if (kf := results[n][1]) is not None}
    parts = [p for n in names if (p := results[n][2]) is not None]
    return maps, keyframes, parts, results[names[0]][3]


class MapsStage(Stage[MapsInputs, Maps]):
    """Render and map every robot of the scenario."""

    name = "maps"
    input_type = MapsInputs
    uses_workers = True
    components = ("segmenter", "encoder")
    worker_preload = (
        "roman_sim.pipeline.stages.maps_job",
        "roman_sim.pipeline.stages.maps_robot",
        "roman_sim.pipeline.stages.maps_input",
        "roman_sim.world",
        "roman_sim.sim.robot",
        "roman_sim.sim.source",
        "roman_sim.sim.render",
        "cv2",
    )

    def applies(self, ctx: RunContext) -> bool:
        return ctx.submaps_dir is None

    def config_parts(self, ctx: RunContext) -> list[JSON]:
        from roman_sim.pipeline.stages.maps_sources import fingerprints

        sc = ctx.scenario.model_dump(mode="json")
        sequences = fingerprints(ctx.scenario.robots)
        return [
            sc["robots"],
            sc["frontend"],
            sc["mapping"],
            *([sequences] if sequences else []),
            *(["visual"] if ctx.scenario.uses_visual else []),
        ]

    def run(self, ctx: RunContext, inputs: MapsInputs, tasks: TaskRunner) -> Maps:
        sc = ctx.scenario
        world = None if inputs.world is None else inputs.world.world
        maps, keyframes, parts, snapshot = map_robots(ctx, world, tasks)
        grades = None
        if parts:
            grader = FrontEndGrader.from_parts(parts, sc.frontend.semantics.group_of, seed=sc.seed)
            grader.appearance = _appearance_kernel(ctx, world)
            grades = grader.result(sc.frontend.segmenter.name, sc.frontend.encoder.name)
        return Maps(maps, _rgb_notes(ctx) + _odometry_notes(ctx, maps), keyframes, grades, snapshot)

    def save(self, out: Maps, ctx: RunContext) -> list[str]:
        files = save_per_robot(ctx, "maps", out.maps, save_segment_map, out.notes)
        if out.keyframes:
            files += save_per_robot(ctx, "keyframes", out.keyframes, save_keyframes, [])
        if out.frontend is not None:
            write_record(ctx.run_dir / FRONTEND_JSON, out.frontend)
            files.append(FRONTEND_JSON)
        if out.snapshot is not None:
            save_snapshot(ctx.run_dir / SNAPSHOT_NPZ, out.snapshot)
            files.append(SNAPSHOT_NPZ)
        return files

    def load(self, ctx: RunContext, files: list[str]) -> Maps:
        maps, notes = load_per_robot(ctx, "maps", load_segment_map)
        keyframes = load_per_robot(ctx, "keyframes", load_keyframes)[0] if ctx.scenario.uses_visual else {}
        grades = None
        if FRONTEND_JSON in files:
            grades = read_record(ctx.run_dir / FRONTEND_JSON, FrontEndGrades)
        snapshot = load_snapshot(ctx.run_dir / SNAPSHOT_NPZ) if SNAPSHOT_NPZ in files else None
        return Maps(maps, notes, keyframes, grades, snapshot)


def _appearance_kernel(ctx: RunContext, world: World | None) -> Callable[[int, int], float] | None:
    """The simulated encoder's appearance kernel of two objects (``AppearanceModel.kernel`` of their
    looks: the world's, or the first sequence table's), for the grades' appearance table."""
    from roman_sim.frontend.components import encoder_spec
    from roman_sim.interop.looks import world_instances

    sc = ctx.scenario
    if not encoder_spec(sc.frontend.encoder).reads_truth or world is None:
        return None
    inst = world_instances(world)
    model = sc.frontend.semantics.appearance

    def kernel(a: int, b: int) -> float:
        return model.kernel(inst[a], inst[b]) if a in inst and b in inst else 0.0

    return kernel


def _rgb_notes(ctx: RunContext) -> list[str]:
    """A note (and a warning) for each robot whose user segmenter or encoder will get no RGB."""
    fe = ctx.scenario.frontend
    entries = (("segmenter", fe.segmenter), ("encoder", fe.encoder))
    users = [f"{kind} {e.name!r}" for kind, e in entries if ":" in e.name]
    notes = []
    for r in ctx.scenario.robots:
        if users and not r.render_rgb:
            notes.append(
                f"robot {r.name} renders no RGB (render_rgb: false): the user {' and '.join(users)} got rgb=None"
            )
            log.warning(notes[-1])
    return notes


def _odometry_notes(ctx: RunContext, maps: dict[str, SegmentMap]) -> list[str]:
    """Which odometry each robot used, when one robot's came from outside (none otherwise: every robot used its own)."""
    from roman_sim.pipeline.stages.maps_input import odometry_used

    robots = ctx.scenario.robots
    if all(r.odometry is None for r in robots):
        return []
    return [f"robot {r.name}: odometry {odometry_used(r)}; {len(maps[r.name].times)} frames mapped" for r in robots]
