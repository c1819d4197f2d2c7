"""Relevant pairs of a scenario from its planned trajectories, before anything is rendered.

Which submap pairs should align depends only on where the submap centres are: the
pipeline places a centre whenever a robot's *odometry* has moved ``submap_center_dist``
(or ``submap_center_time`` has passed) and scores the pair of two centres by their *true*
poses. Both trajectories follow from the world, the paths and the seed alone (driving and
drift, no rendering), so a crossing scene's plan (``scenes.build_crossing``) drives every
robot through the world's truth (no model), and the functions here place the centres with the
pipeline's own rule (``mapping.submap.center_indices``) and score the pairs with the
evaluation's own functions (``select_pairs``, ``truths_for_pairs``) on submaps that carry
only their truth. The counts are those of the
finished run, to the pair, as long as relevance is by distance (the default): relevance by
shared objects needs the maps, and is refused.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence

import numpy as np

from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import gravity_aligned
from roman_sim.evaluation.bins import bin_groups
from roman_sim.evaluation.pairs import AmbiguityFn, PairTruth, select_pairs, truths_for_pairs
from roman_sim.mapping.submap import SubmapConfig, center_indices
from roman_sim.mapping.types import Submap, SubmapTruth
from roman_sim.pipeline.scenario import Scenario
from roman_sim.sim.robot import DrivenRun

log = logging.getLogger(__name__)


def _stub(robot: str, index: int, t: float, T_odom: np.ndarray, T_world: np.ndarray) -> Submap:
    """A submap without segments: its centre poses only."""
    return Submap(
        robot=robot,
        index=index,
        t=float(t),
        T_odom_submap=gravity_aligned(T_odom),
        segment_ids=np.zeros(0, np.int64),
        centers=np.zeros((0, 3)),
        volumes=np.zeros(0),
        shape=np.zeros((0, 3)),
        descriptors=np.zeros((0, 0), np.float32),
        extents=np.zeros((0, 3)),
        truth=SubmapTruth(gravity_aligned(T_world), np.zeros(0, np.int64), np.zeros(0)),
    )


def submaps_along(runs: Mapping[str, DrivenRun], cfg: SubmapConfig) -> list[Submap]:
    """The submaps (without segments) the pipeline places along each robot's driven run."""
    out = []
    for robot, (t, T_wb, T_ob) in runs.items():
        for k, i in enumerate(center_indices(t, T_ob, cfg)):
            out.append(_stub(robot, k, float(t[i]), T_ob[i], T_wb[i]))
    return out


def scored_pairs(subs: list[Submap], sc: Scenario, ambiguity_fn: AmbiguityFn | None = None) -> list[PairTruth]:
    """The truth of every pair of ``subs`` the evaluation of ``sc`` scores (ambiguity NaN without ``ambiguity_fn``)."""
    if sc.evaluation.relevance != "distance":
        raise ConfigError(
            f"evaluation.relevance: {sc.evaluation.relevance!r} needs the maps; pairs can be planned only "
            "with relevance by distance"
        )
    return truths_for_pairs(select_pairs(subs, sc.evaluation).pairs, ambiguity_fn, sc.evaluation)


def relevant_per_bin(truths: Sequence[PairTruth], edges: Sequence[float]) -> list[int]:
    """Relevant cross-robot pairs whose heading difference falls in each bin of ``edges``."""
    inter = [t for t in truths if t.kind == "inter"]
    groups = bin_groups(inter, [t.heading_diff_deg for t in inter], edges)
    return [sum(1 for t in g if t.relevant) for g in groups]
