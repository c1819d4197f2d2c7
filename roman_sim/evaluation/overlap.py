"""How much the robots share, from truth alone (no aligning): relevant pairs per robot pair,
the robots' overlap graph, and what relevant pairs have in common.

- ``relevant_counts``: per robot pair, the cross-robot submap pairs whose true centres lie
  within the relevance distance (10 m), from submap centres alone (so a scenario can be
  measured from its planned trajectories, before anything is rendered).
- ``overlap_graph``: robots joined where a robot pair has at least ``MIN_RELEVANT_PAIRS``
  (10) relevant pairs; robots that meet the way Kimera-Multi's do form one connected graph.
- ``robot_pair_counts``: the same figure from a run's scored pairs (``metrics.json``).
- ``revisit_overlap``: per relevant pair of submaps, the overlap (shared true objects over
  the smaller submap's objects) and the shared objects, with medians: how much of a
  revisit is a replay.
- ``revisit_figures``: the same medians from a run's scored pairs, over all relevant
  cross-robot pairs and per robot pair (``metrics.json``'s ``revisits``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.pairs import pair_truth, select_pairs
from roman_sim.mapping.types import Submap

#: Relevant cross-robot pairs that make two robots neighbours in the overlap graph.
MIN_RELEVANT_PAIRS = 10
#: A robot pair's key in ``metrics.json``: the two names joined by this.
KEY_SEP = "|"

RobotPair = tuple[str, str]


@dataclass
class PairCounts:
    """Pairs scored and how many should align (relevant)."""

    n_pairs: int
    n_relevant: int


@dataclass(frozen=True)
class RevisitFigures:
    """What relevant cross-robot pairs share: their count and the median overlap and shared objects
    (None without relevant pairs)."""

    n_relevant: int
    median_overlap: float | None
    median_shared_objects: float | None


def relevant_counts(centres: Mapping[str, NDArray[np.float64]], relevant_dist_m: float = 10.0) -> dict[RobotPair, int]:
    """Cross-robot submap pairs with true centres within ``relevant_dist_m``, for every robot pair.

    Args:
        centres: robot -> (M, 2 or 3) true submap centres; robot pairs follow its order.
        relevant_dist_m: the relevance distance.
    """
    trees = {r: cKDTree(np.asarray(c, dtype=np.float64).reshape(len(c), -1)) for r, c in centres.items() if len(c)}
    out: dict[RobotPair, int] = {}
    for a, b in combinations(list(centres), 2):
        ok = a in trees and b in trees
        out[(a, b)] = int(trees[a].count_neighbors(trees[b], relevant_dist_m)) if ok else 0
    return out


@dataclass(frozen=True)
class OverlapGraph:
    """Robots joined where they share at least ``min_pairs`` relevant cross-robot pairs.

    Attributes:
        robots: every robot, in order.
        counts: relevant cross-robot pairs per robot pair.
        min_pairs: the threshold of an edge.
        components: connected groups of robots (each in robot order; the first robot's first).
    """

    robots: list[str]
    counts: dict[RobotPair, int]
    min_pairs: int
    components: list[list[str]] = field(default_factory=list)

    @property
    def edges(self) -> list[RobotPair]:
        """Robot pairs with at least ``min_pairs`` relevant pairs."""
        return [k for k, n in self.counts.items() if n >= self.min_pairs]

    @property
    def connected(self) -> bool:
        """Whether every robot is reachable from every other (a single robot is connected)."""
        return len(self.components) <= 1

    def describe(self) -> str:
        """One line: connected, or the groups."""
        head = f"Overlap graph (robot pairs with >= {self.min_pairs} relevant cross-robot pairs)"
        if self.connected:
            return f"{head}: connected"
        groups = " ".join("{" + ", ".join(c) + "}" for c in self.components)
        return f"{head}: NOT connected, {len(self.components)} groups {groups}"


def overlap_graph(
    counts: Mapping[RobotPair, int], robots: Sequence[str], min_pairs: int = MIN_RELEVANT_PAIRS
) -> OverlapGraph:
    """The overlap graph of ``robots`` from per-pair ``counts`` (pairs not listed count 0)."""
    index = {r: i for i, r in enumerate(robots)}
    edges = [(index[a], index[b]) for (a, b), n in counts.items() if n >= min_pairs]
    rows, cols = [e[0] for e in edges], [e[1] for e in edges]
    adj = coo_matrix((np.ones(len(edges)), (rows, cols)), shape=(len(robots), len(robots)))
    _, label = connected_components(adj, directed=False)
    groups: dict[int, list[str]] = {}
    for r in robots:  # components in robot order, each listing its robots in order
        groups.setdefault(int(label[index[r]]), []).append(r)
    return OverlapGraph(list(robots), dict(counts), min_pairs, list(groups.values()))


def robot_pair_counts(pairs: Iterable[tuple[str, str, bool]]) -> dict[str, PairCounts]:
    """Scored and relevant cross-robot pairs per robot pair, from ``(robot_a, robot_b, relevant)`` of each pair.

    Keys are ``"a|b"`` with the names sorted.
    """
    out: dict[str, PairCounts] = {}
    for ra, rb, relevant in pairs:
        if ra == rb:
            continue
        entry = out.setdefault(KEY_SEP.join(sorted((ra, rb))), PairCounts(0, 0))
        entry.n_pairs += 1
        entry.n_relevant += int(bool(relevant))
    return dict(sorted(out.items()))


def counts_by_pair(robot_pairs: Mapping[str, PairCounts]) -> dict[RobotPair, int]:
    """``robot_pair_counts`` output as relevant counts keyed by (robot, robot)."""
    out: dict[RobotPair, int] = {}
    for key, entry in robot_pairs.items():
        a, b = key.split(KEY_SEP, 1)
        out[(a, b)] = entry.n_relevant
    return out


def _median_or_none(values: list[float]) -> float | None:
    """Median of the finite ``values`` (None without any)."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if len(v) else None


def revisit_figures(pairs: Iterable[tuple[str, str, bool, float, int]]) -> dict[str, RevisitFigures]:
    """Median overlap and shared objects of the relevant cross-robot pairs, overall and per robot pair.

    Args:
        pairs: ``(robot_a, robot_b, relevant, overlap, shared_objects)`` of each distinct pair.

    Returns:
        ``{"all": figures, "a|b": figures, ...}`` (robot pairs sorted, names sorted within a
        key); the medians are None without relevant pairs (an overlap is NaN when a submap has no
        object id: such pairs count but give no overlap). Empty without cross-robot pairs.
    """
    groups: dict[str, list[tuple[float, int]]] = {}
    seen_inter = False
    for ra, rb, relevant, overlap, shared in pairs:
        if ra == rb:
            continue
        seen_inter = True
        if not relevant:
            continue
        for key in ("all", KEY_SEP.join(sorted((ra, rb)))):
            groups.setdefault(key, []).append((float(overlap), int(shared)))
    if not seen_inter:
        return {}
    out: dict[str, RevisitFigures] = {}
    for key in ["all", *sorted(k for k in groups if k != "all")]:
        g = groups.get(key, [])
        out[key] = RevisitFigures(len(g), _median_or_none([o for o, _ in g]), _median_or_none([float(n) for _, n in g]))
    return out


@dataclass(frozen=True)
class SharedView:
    """What one relevant submap pair shares (from its truth)."""

    a: str
    b: str
    robot_a: str
    robot_b: str
    center_dist_m: float
    overlap: float
    shared_objects: int


@dataclass
class RevisitOverlap:
    """Overlap and shared objects of the relevant pairs of one kind, with their medians.

    Attributes:
        views: one entry per relevant pair.
        median_overlap: median overlap (NaN pairs left out; NaN without any).
        median_shared: median shared objects (NaN without pairs).
        by_robot_pair: robot pair -> (pairs, median overlap, median shared objects).
    """

    views: list[SharedView]
    median_overlap: float
    median_shared: float
    by_robot_pair: dict[RobotPair, tuple[int, float, float]]


def _medians(views: list[SharedView]) -> tuple[float, float]:
    ov = np.array([v.overlap for v in views], dtype=np.float64)
    ov = ov[~np.isnan(ov)]
    shared = np.array([v.shared_objects for v in views], dtype=np.float64)
    return (float(np.median(ov)) if len(ov) else float("nan")), (
        float(np.median(shared)) if len(shared) else float("nan")
    )


def revisit_overlap(submaps: list[Submap], cfg: EvalConfig | None = None, kind: str = "inter") -> RevisitOverlap:
    """Overlap and shared objects of every relevant pair of ``kind`` (``inter``: two robots; ``intra``: one).

    Pairs are those the evaluation would score (``select_pairs``), relevant by ``cfg``; only
    the submaps' truth is read (object ids and true centres), nothing is aligned.
    """
    cfg = cfg or EvalConfig()
    views = []
    for a, b in select_pairs(submaps, cfg).pairs:
        if (a.robot != b.robot) != (kind == "inter"):
            continue
        t = pair_truth(a, b, cfg=cfg)
        if t.relevant:
            views.append(SharedView(t.a, t.b, t.robot_a, t.robot_b, t.center_dist_m, t.overlap, t.shared_objects))
    med_ov, med_sh = _medians(views)
    groups: dict[RobotPair, list[SharedView]] = {}
    for v in views:
        groups.setdefault((v.robot_a, v.robot_b), []).append(v)
    per = {k: (len(g), *_medians(g)) for k, g in groups.items()}
    return RevisitOverlap(views, med_ov, med_sh, per)
