"""Stage ``maps``: simulate (or read) every robot and map its frames into a ``SegmentMap``.

Simulated robots are planned together (a path may be defined relative to an earlier
robot's), then rendered and mapped one by one; a robot with a ``source`` is read from its
TUM RGB-D folder instead (``roman_sim.pipeline.sources``) and mapped the same way.
When a scenario lists the ``visual`` method, the same frames also give each robot's visual
keyframes (ORB features with depth and BoW vectors, ``frontend.keyframes``), saved as
``keyframes/<robot>.npz`` with poses in the robot's odometry frame.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import StorageError
from roman_sim.evaluation.frontend import FrontEndGrader, GraderPart
from roman_sim.evaluation.frontend_types import FrontEndGrades
from roman_sim.mapping.io import load_keyframes, load_segment_map, save_keyframes, save_segment_map
from roman_sim.mapping.mapper import SegmentMap
from roman_sim.mapping.types import KeyframeSet
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.robot_mapping import RobotMapping, map_one
from roman_sim.pipeline.stages.base import Stage
from roman_sim.pipeline.stages.notes import load_per_robot, save_per_robot
from roman_sim.pipeline.stages.world import WorldOutput
from roman_sim.report.frontend import plot_frontend_grades

log = logging.getLogger(__name__)


FRONTEND_JSON = "maps/frontend.json"
FRONTEND_PNG = "plots/frontend.png"


@dataclass
class Maps:
    """Each robot's segment map (robot name -> map, in scenario order), the stage's notes, the
    front end's grades and, when the visual method runs, each robot's keyframes (poses in its
    odometry frame).

    ``frontend`` grades whatever segmenter and encoder ran against the frames' instance truth,
    over every robot (None when no frame has instance truth); ``written`` lists the plot.
    """

    maps: dict[str, SegmentMap]
    notes: list[str] = field(default_factory=list)
    keyframes: dict[str, KeyframeSet] = field(default_factory=dict)
    frontend: FrontEndGrades | None = None
    written: list[str] = field(default_factory=list)


def map_robots(
    ctx: RunContext, world: Any, paths: dict[str, Any]
) -> tuple[dict[str, SegmentMap], dict[str, KeyframeSet], list[GraderPart]]:
    """Every robot, one ``map_one`` task per robot on the run's executor (scenario order).

    Each finished robot's map (and keyframes) is written to ``maps/<robot>.npz``
    (``keyframes/<robot>.npz``) at once and checkpointed with its share of the front-end
    grades, so an interrupted run maps only the robots that did not finish. What is returned
    is what was written and read back, so fresh and resumed robots give the same bytes.
    Returns the maps, the keyframes (robots that have them) and the grade parts (robots with
    instance truth), in scenario order.
    """
    from roman_sim.core.atomic import write_arrays
    from roman_sim.pipeline.checkpoint import Checkpoint
    from roman_sim.pipeline.tasks import map_robot_task

    ex = ctx.tasks()
    done = Checkpoint(ctx.run_dir, "maps", None if ctx.fresh else ctx.stage_key)
    names = [r.name for r in ctx.scenario.robots]
    files = {n: ctx.run_dir / "maps" / f"{n}.npz" for n in names}
    kf_files = {n: ctx.run_dir / "keyframes" / f"{n}.npz" for n in names}
    part_files = {n: done.folder / f"{n}.grades.npz" for n in names}
    results: dict[str, tuple[SegmentMap, KeyframeSet | None, GraderPart | None]] = {}

    def read_back(name: str, has_kf: bool, has_part: bool) -> RobotMapping:
        part = None
        if has_part:
            with np.load(part_files[name], allow_pickle=False) as z:
                part = GraderPart.from_arrays(z)
        return (load_segment_map(files[name]), load_keyframes(kf_files[name]) if has_kf else None, part)

    for name in names:
        rec = done.get(name)
        if rec is None or not files[name].is_file() or rec.get("sha256") != _sha256(files[name]):
            continue
        ok = all(
            rec.get(k) is None or (f.is_file() and rec.get(k) == _sha256(f))
            for k, f in (("keyframes_sha256", kf_files[name]), ("grades_sha256", part_files[name]))
        )
        if ok:
            results[name] = read_back(
                name, rec.get("keyframes_sha256") is not None, rec.get("grades_sha256") is not None
            )
            log.info("robot %s: reusing the map of an interrupted run", name)
    todo = [r for r in ctx.scenario.robots if r.name not in results]
    sc_json = ctx.scenario.model_dump_json()
    local = ex.kind == "serial"
    args = [(sc_json, r.name, paths.get(r.name), str(ctx.run_dir), world if local else None) for r in todo]
    fn = (lambda sc, name, path, d, w: map_one(ctx, w, _robot(ctx, name), path)) if local else map_robot_task
    ctx.progress.start("maps:robots", len(files))
    ctx.progress.advance("maps:robots", len(results))
    for i, (smap, kf, part) in ex.run_tasks(fn, args, [f"mapping robot {r.name}" for r in todo]):
        name = todo[i].name
        save_segment_map(files[name], smap)
        entry: dict[str, Any] = {"sha256": _sha256(files[name]), "keyframes_sha256": None, "grades_sha256": None}
        if kf is not None:
            save_keyframes(kf_files[name], kf)
            entry["keyframes_sha256"] = _sha256(kf_files[name])
        if part is not None:
            write_arrays(part_files[name], part.arrays())
            entry["grades_sha256"] = _sha256(part_files[name])
        done.put(name, entry)
        results[name] = read_back(name, kf is not None, part is not None)
        ctx.progress.advance("maps:robots")
    ctx.progress.end("maps:robots")
    maps = {n: results[n][0] for n in names}
    keyframes = {n: kf for n in names if (kf := results[n][1]) is not None}
    parts = [p for n in names if (p := results[n][2]) is not None]
    return maps, keyframes, parts


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
        return [
            sc["robots"],
            sc["frontend"],
            sc["mapping"],
            *([sequences] if sequences else []),
            *(["visual"] if ctx.scenario.uses_visual else []),
        ]

    def run(self, ctx: RunContext, world: WorldOutput | None = None, **_: Any) -> Maps:
        from roman_sim.sim.robot import plan_paths

        sc = ctx.scenario
        simulated = sc.simulated_robots()
        assert world is not None or not simulated, "the maps stage needs the world for simulated robots"
        paths = plan_paths(world.world, simulated, sc.seed) if world is not None and simulated else {}
        maps, keyframes, parts = map_robots(ctx, None if world is None else world.world, paths)
        grades = None
        if parts:
            grader = FrontEndGrader.from_parts(parts, sc.frontend.semantics.group_of, seed=sc.seed)
            grades = grader.result(sc.frontend.segmenter.name, sc.frontend.encoder.name)
        return Maps(maps, _rgb_notes(ctx), keyframes, grades)

    def save(self, out: Maps, ctx: RunContext) -> list[str]:
        files = save_per_robot(ctx, "maps", out.maps, save_segment_map, out.notes)
        if out.keyframes:
            files += save_per_robot(ctx, "keyframes", out.keyframes, save_keyframes, [])
        if out.frontend is not None:
            write_json(ctx.run_dir / FRONTEND_JSON, out.frontend.to_json())
            plot_frontend_grades(out.frontend, ctx.run_dir / FRONTEND_PNG)
            files += [FRONTEND_JSON, FRONTEND_PNG]
        return files

    def load(self, ctx: RunContext, files: list[str]) -> Maps:
        maps, notes = load_per_robot(ctx, "maps", load_segment_map)
        keyframes = load_per_robot(ctx, "keyframes", load_keyframes)[0] if ctx.scenario.uses_visual else {}
        grades = None
        if FRONTEND_JSON in files:
            path = ctx.run_dir / FRONTEND_JSON
            try:
                grades = FrontEndGrades.from_json(json.loads(path.read_text(encoding="utf-8")))
            except (OSError, ValueError) as err:
                raise StorageError(f"{path}: unreadable front-end grades ({type(err).__name__})") from None
        return Maps(maps, notes, keyframes, grades, [f for f in files if f.endswith(".png")])


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
