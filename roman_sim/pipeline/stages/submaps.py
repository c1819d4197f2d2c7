"""Stage ``submaps``: cut each robot's segment map into gravity-aligned submaps.

When the maps stage extracted visual keyframes, each submap carries those nearest its
centre in time (``attach_keyframes``), poses in the submap frame.

A run may instead start from the user's saved submaps (``--submaps DIR`` with one
``<robot>.npz`` per robot of the scenario, as ``roman_sim.mapping.io.save_submaps`` writes
them); files of other robots in that folder are never read.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from roman_sim.core.errors import ConfigError
from roman_sim.core.jsontypes import JSON
from roman_sim.mapping.io import load_submaps, save_submaps
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.context import RunContext
from roman_sim.pipeline.stagefiles import load_per_robot, save_per_robot
from roman_sim.pipeline.stages.base import Stage, Timings
from roman_sim.pipeline.stages.maps import Maps
from roman_sim.runner.taskrunner import TaskRunner

if TYPE_CHECKING:
    from roman_sim.mapping.mapper import SegmentMap
    from roman_sim.mapping.submap import SubmapConfig
    from roman_sim.mapping.types import KeyframeSet


@dataclass
class Submaps:
    """Each robot's submaps (robot name -> submaps in index order) and the stage's notes."""

    submaps: dict[str, list[Submap]]
    notes: list[str] = field(default_factory=list)
    timings: Timings = field(default_factory=dict, repr=False, compare=False)

    def all(self) -> list[Submap]:
        """Every submap, robot by robot."""
        return [s for subs in self.submaps.values() for s in subs]

    def by_name(self) -> dict[str, Submap]:
        """Submap name (``robot/index``) -> submap."""
        return {s.name: s for s in self.all()}


@dataclass(frozen=True)
class SubmapsInputs:
    """The maps (None when the run starts from the user's saved submaps)."""

    maps: Maps | None = None


def submaps_task(smap: SegmentMap, cfg: SubmapConfig, keyframes: KeyframeSet | None) -> list[Submap]:
    """The stage's worker job: one robot's submaps (``build_submaps``), carrying its keyframes when it has them."""
    from roman_sim.align.visual import attach_keyframes
    from roman_sim.mapping.submap import build_submaps

    subs = build_submaps(smap, cfg)
    return attach_keyframes(subs, keyframes) if keyframes is not None else subs


def _user_files(ctx: RunContext) -> dict[str, Path]:
    """``<robot>.npz`` of each scenario robot in the user's submaps folder (ConfigError if one is missing)."""
    d = ctx.submaps_dir
    assert d is not None
    if not d.is_dir():
        raise ConfigError(f"--submaps {d}: not a folder")
    files = {r.name: d / f"{r.name}.npz" for r in ctx.scenario.robots}
    missing = [f"{r}.npz" for r, p in files.items() if not p.is_file()]
    if missing:
        found = ", ".join(sorted(p.name for p in d.glob("*.npz"))) or "none"
        raise ConfigError(f"--submaps {d}: no {', '.join(missing)} for the scenario's robots (found: {found})")
    return files


class SubmapsStage(Stage[SubmapsInputs, Submaps]):
    """Build submaps from the maps (or load the user's); on a local pool, one robot per worker."""

    name = "submaps"
    input_type = SubmapsInputs
    uses_workers = True
    code = ("roman_sim.mapping.submap", "roman_sim.align.visual.keyframes")  # its worker job's
    worker_preload = (__name__, "roman_sim.mapping.submap", "roman_sim.align.visual")

    def config_parts(self, ctx: RunContext) -> list[JSON]:
        parts: list[JSON] = [ctx.scenario.model_dump(mode="json")["submaps"]]
        if ctx.submaps_dir is not None:  # the user's files by content, not by path
            parts.append({r: hashlib.sha256(p.read_bytes()).hexdigest() for r, p in _user_files(ctx).items()})
        return parts

    def run(self, ctx: RunContext, inputs: SubmapsInputs, tasks: TaskRunner) -> Submaps:
        if ctx.submaps_dir is not None:
            out = {}
            for robot, path in _user_files(ctx).items():
                subs = load_submaps(path)
                wrong = sorted({s.robot for s in subs} - {robot})
                if wrong:
                    raise ConfigError(f"--submaps {path}: holds submaps of robot(s) {', '.join(wrong)}, not {robot}")
                out[robot] = subs
            return Submaps(out)
        maps = inputs.maps
        if maps is None:
            raise ConfigError("the submaps stage needs the maps (or --submaps)")
        names = list(maps.maps)
        args = [(maps.maps[n], ctx.scenario.submaps, maps.keyframes.get(n)) for n in names]
        if tasks.kind != "local" or len(names) < 2:  # Dask workers would get every map over the network
            return Submaps({n: submaps_task(*a) for n, a in zip(names, args)})
        done = dict(tasks.run_unkept(submaps_task, args, [f"cutting the submaps of robot {n}" for n in names]))
        return Submaps({n: done[i] for i, n in enumerate(names)})

    def save(self, out: Submaps, ctx: RunContext) -> list[str]:
        return save_per_robot(ctx, "submaps", out.submaps, save_submaps, out.notes)

    def load(self, ctx: RunContext, files: list[str]) -> Submaps:
        return Submaps(*load_per_robot(ctx, "submaps", load_submaps))
