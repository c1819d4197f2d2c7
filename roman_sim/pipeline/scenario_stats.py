"""Whether a scenario's robots meet, before anything is rendered or aligned.

The robots' paths are planned and driven (poses and odometry only, no rendering); submap
centres are placed the way the submaps stage places them (``mapping.submap.center_indices``
on the odometry: every ``submap_center_dist`` metres or ``submap_center_time`` seconds),
and each centre's true position is the true pose at that step, so the relevant
cross-robot pairs counted here are the ones a run of the scenario scores (relevance by the
distance between true centres, ``evaluation.relevant_dist_m``).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError
from roman_sim.evaluation.overlap import MIN_RELEVANT_PAIRS, OverlapGraph, overlap_graph, relevant_counts
from roman_sim.mapping.submap import center_indices
from roman_sim.pipeline.scenario import Scenario
from roman_sim.sim.source import SimulatedRobot
from roman_sim.world import HasTruth

log = logging.getLogger(__name__)


@dataclass
class ScenarioStats:
    """Submap centres and relevant cross-robot pairs of a scenario, from its planned trajectories.

    Attributes:
        scenario: the scenario's name.
        relevant_dist_m: the relevance distance used.
        centres: robot -> (M, 3) true submap centres.
        length_m: robot -> distance driven (m).
        offset_m: robot -> its drawn lateral offset (m, left of its travel; 0 without one).
        graph: the overlap graph (its ``counts`` are the relevant pairs per robot pair).
    """

    scenario: str
    relevant_dist_m: float
    centres: dict[str, NDArray[np.float64]]
    length_m: dict[str, float]
    offset_m: dict[str, float]
    graph: OverlapGraph

    @property
    def counts(self) -> dict[tuple[str, str], int]:
        """Relevant cross-robot pairs per robot pair."""
        return self.graph.counts


def centres_along(
    sources: Sequence[SimulatedRobot], sc: Scenario
) -> tuple[dict[str, NDArray[np.float64]], dict[str, float]]:
    """Per simulated robot along its driven run: true submap centres (M, 3) and the distance driven (m)."""
    centres, lengths = {}, {}
    for src in sources:
        run = src.run
        idx = center_indices(run.t, run.T_odom_body, sc.submaps)
        centres[src.name] = run.T_world_body[idx, :3, 3]
        lengths[src.name] = float(np.linalg.norm(np.diff(run.T_world_body[:, :3, 3], axis=0), axis=1).sum())
    return centres, lengths


def scenario_stats(sc: Scenario, min_pairs: int = MIN_RELEVANT_PAIRS, world: HasTruth | None = None) -> ScenarioStats:
    """Relevant cross-robot pairs per robot pair and the overlap graph of ``sc`` (no rendering).

    Args:
        sc: the scenario (every robot simulated).
        min_pairs: relevant pairs that make two robots neighbours.
        world: the scenario's world when already generated (else it is generated).

    Raises:
        ConfigError: a robot is read from a recorded sequence (it has no planned trajectory), or
            the scenario's relevance is not by distance.
    """
    recorded = [r.name for r in sc.robots if not r.simulated]
    if recorded:
        raise ConfigError(
            f"scenario stats: robot(s) {', '.join(recorded)} are read from recorded sequences; "
            "only simulated robots have planned trajectories"
        )
    if sc.evaluation.relevance != "distance":
        raise ConfigError(
            f"scenario stats: evaluation.relevance is {sc.evaluation.relevance!r}; relevant pairs can be "
            "counted before mapping only by distance (relevance: distance)"
        )
    if world is None:
        from roman_sim.world import generate_truth

        world = generate_truth(sc.world.spec(), sc.seed)
    from roman_sim.sim.source import robot_sources

    sources = robot_sources(world, sc.robots, sc.seed)
    centres, lengths = centres_along(sources, sc)
    counts = relevant_counts(centres, sc.evaluation.relevant_dist_m)
    graph = overlap_graph(counts, list(centres), min_pairs)
    log.info("scenario %s: %s", sc.name, graph.describe())
    offsets = {s.name: float(s.path.offset_m) for s in sources}
    return ScenarioStats(sc.name, sc.evaluation.relevant_dist_m, centres, lengths, offsets, graph)
