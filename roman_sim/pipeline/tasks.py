"""The tasks a run sends to its workers: map one robot, cut its submaps, align one chunk of submap pairs.

Tasks get the scenario as JSON (the worker validates it again) and return plain data; the
calling process writes every file. A mapping task gets the world pickled (``PickledWorld``,
from a local pool) or regenerates it from the scenario (Dask workers, possibly on other
machines; worlds are deterministic in spec and seed). A worker keeps the last world it
generated and the aligners it built, so consecutive tasks of one run do not rebuild them.
"""

from __future__ import annotations

import dataclasses
import logging
import pickle
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, cast

import numpy as np

from roman_sim.align.base import Aligner, AlignResult
from roman_sim.core.jsontypes import JSON
from roman_sim.mapping.types import Submap

if TYPE_CHECKING:
    from roman_sim.mapping.mapper import SegmentMap
    from roman_sim.mapping.submap import SubmapConfig
    from roman_sim.mapping.types import KeyframeSet
    from roman_sim.pipeline.robot_mapping import RobotMapping
    from roman_sim.pipeline.scenario import Scenario
    from roman_sim.world import World

log = logging.getLogger(__name__)


class ResultJSON(TypedDict):
    """An ``AlignResult`` as JSON (``result_to_json``)."""

    method: str
    T_a_b: list[list[float]] | None
    associations: list[list[int]]
    scores: list[float]
    runtime_s: float
    reason: str | None
    info: dict[str, JSON]


class ChunkRecord(ResultJSON):
    """One aligner's result on one pair of a chunk: the pair's submap names and the result."""

    a: str
    b: str


@lru_cache(maxsize=2)
def _scenario(scenario_json: str) -> Scenario:
    from roman_sim.pipeline.scenario import Scenario

    return Scenario.model_validate_json(scenario_json)


@lru_cache(maxsize=1)
def _world(world_json: str, seed: int) -> World:
    from roman_sim.pipeline.scenario import WorldRef
    from roman_sim.world import generate

    return generate(WorldRef.model_validate_json(world_json).spec(), seed)


@dataclasses.dataclass(frozen=True)
class PickledWorld:
    """A world pickled once by the run's process, for its local workers (loading it takes a fraction
    of the seconds generating it does).

    The world goes without its ``MjSpec``, which cannot be pickled and which only exporting
    reads; the compiled model, truth and meshes are the generated world's, byte for byte.
    """

    data: bytes

    @classmethod
    def of(cls, world: World) -> PickledWorld:
        """``world`` pickled (its ``mjspec`` left out)."""
        return cls(pickle.dumps(dataclasses.replace(world, mjspec=None), protocol=pickle.HIGHEST_PROTOCOL))

    def load(self) -> World:
        """The world back."""
        world = pickle.loads(self.data)  # noqa: S301 (bytes this run's own process pickled)
        return cast("World", world)


def map_robot_task(
    scenario_json: str, robot: str, run_dir: str, world: World | PickledWorld | None = None
) -> RobotMapping:
    """Map ``robot``: rendered along its planned path, or read from its ``source``; its ``SegmentMap``.

    ``world`` is the world itself in-process, pickled from a local pool, None on Dask:
    workers then regenerate it from the scenario (same bytes). A robot read from a TUM folder
    needs that folder on the worker.
    """
    from roman_sim.pipeline.context import RunContext
    from roman_sim.pipeline.robot_mapping import map_one

    sc = _scenario(scenario_json)
    cfg = next(r for r in sc.robots if r.name == robot)
    if isinstance(world, PickledWorld):
        world = world.load() if cfg.source is None else None
    if world is None and cfg.source is None:
        world = _world(sc.world.model_dump_json(), sc.seed)
    return map_one(RunContext(sc, Path(run_dir)), world, cfg)


def submaps_task(smap: SegmentMap, cfg: SubmapConfig, keyframes: KeyframeSet | None) -> list[Submap]:
    """One robot's submaps (``build_submaps``), carrying its keyframes when it has them."""
    from roman_sim.align.visual import attach_keyframes
    from roman_sim.mapping.submap import build_submaps

    subs = build_submaps(smap, cfg)
    return attach_keyframes(subs, keyframes) if keyframes is not None else subs


@lru_cache(maxsize=4)
def _aligners(aligners_json: str) -> list[tuple[str, Aligner]]:
    import json

    from roman_sim.align import build_aligner
    from roman_sim.pipeline.plugin_guard import guard_aligner

    return [
        (e["label"], guard_aligner(build_aligner(e["method"], e["params"]), e["method"]))
        for e in json.loads(aligners_json)
    ]


def align_chunk_task(aligners_json: str, submaps: dict[str, Submap], pairs: list[tuple[str, str]]) -> list[ChunkRecord]:
    """Every aligner on every pair of the chunk (submaps already public); JSON-ready results in order.

    Returns one record per (pair, aligner), pair-major: ``result_to_json`` of the result
    under the aligner's label.
    """
    from roman_sim.align.checks import remembered_checks

    out: list[ChunkRecord] = []
    labelled = _aligners(aligners_json)
    with remembered_checks():  # each submap's input checks once per chunk, not once per pair and method
        for a, b in pairs:
            for label, aligner in labelled:
                res = aligner.align(submaps[a], submaps[b])
                res.method = label
                out.append({"a": a, "b": b, **result_to_json(res)})
    return out


def _plain(v: object) -> JSON:
    """``v`` with numpy values turned into JSON types (lists, floats, ints, bools)."""
    if isinstance(v, np.ndarray):
        return _plain(v.tolist())
    if isinstance(v, np.generic):
        return _plain(v.item())
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    return str(v)


def result_to_json(res: AlignResult) -> ResultJSON:
    """JSON-ready ``AlignResult`` (floats round-trip exactly through JSON)."""
    return {
        "method": res.method,
        "T_a_b": None if res.T_a_b is None else np.asarray(res.T_a_b).tolist(),
        "associations": np.asarray(res.associations, dtype=np.int64).reshape(-1, 2).tolist(),
        "scores": np.asarray(res.scores, dtype=np.float64).tolist(),
        "runtime_s": float(res.runtime_s),
        "reason": res.reason,
        "info": {str(k): _plain(x) for k, x in res.info.items()},
    }


def result_from_json(d: ResultJSON) -> AlignResult:
    """Inverse of ``result_to_json``."""
    T = None if d["T_a_b"] is None else np.asarray(d["T_a_b"], dtype=np.float64)
    return AlignResult(
        str(d["method"]),
        T,
        np.asarray(d["associations"], dtype=np.int64).reshape(-1, 2),
        np.asarray(d["scores"], dtype=np.float64),
        float(d["runtime_s"]),
        d["reason"],
        dict(d["info"]),
    )
