"""Submap pairs and their ground truth: relative pose, distance, heading, overlap.

A pair ``(a, b)`` is described from a's side: ``T_a_b_true = inv(T_world_a) @ T_world_b``
with the gravity-aligned true submap poses, so an aligner's ``T_a_b`` is compared to it
directly. Which pairs are evaluated:

* every inter-robot pair (submaps of two different robots);
* intra-robot pairs whose submap indices differ by at least ``intra_min_gap`` (default 2:
  consecutive submaps of one robot share most of their segments by construction and say
  nothing about loop closure, so they are left out).

Both kinds can be restricted to pairs whose true centres lie within ``max_center_dist_m``
to keep counts manageable on long runs; relevant pairs are always kept.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import EvaluationError
from roman_sim.geometry import inv_T, yaw_of
from roman_sim.mapping.types import Submap

if TYPE_CHECKING:
    from roman_sim.world.truth import WorldTruth

log = logging.getLogger(__name__)

#: Default relevance distance (m) between true submap centres.
RELEVANT_DIST_M = 10.0
#: Default smallest index gap of an evaluated intra-robot pair.
INTRA_MIN_GAP = 2

PairKind = Literal["inter", "intra"]
#: ``ambiguity_fn(center_xy) -> float``: ground-truth ambiguity of the place at ``center_xy``
#: (e.g. ``functools.partial(place_ambiguity, world_truth, radius_m=15.0)`` bound by the caller).
AmbiguityFn = Callable[[NDArray[np.float64]], float]


@dataclass(frozen=True)
class PairTruth:
    """Ground truth of one submap pair.

    Attributes:
        a, b: submap names (``robot/index``).
        robot_a, robot_b: robot names.
        index_a, index_b: submap indices.
        T_a_b_true: 4x4 true relative pose (maps b's points into a's frame).
        center_dist_m: distance between the true submap centres.
        heading_diff_deg: |yaw| of the true relative pose, in [0, 180].
        overlap: shared true object ids / the smaller submap's number of object ids
            (NaN when either submap has no object id).
        ambiguity: ground-truth ambiguity of the place (midpoint of the two centres), or NaN.
        relevant: whether the pair should align (``center_dist_m <= relevant_dist_m``).
        kind: ``"inter"`` (two robots) or ``"intra"`` (one robot, not neighbours in time).
    """

    a: str
    b: str
    robot_a: str
    robot_b: str
    index_a: int
    index_b: int
    T_a_b_true: NDArray[np.float64]
    center_dist_m: float
    heading_diff_deg: float
    overlap: float
    ambiguity: float
    relevant: bool
    kind: PairKind


def world_ambiguity_fn(truth: "WorldTruth", radius_m: float = 15.0) -> AmbiguityFn:
    """``ambiguity_fn`` backed by the world's ground-truth place ambiguity (imported lazily)."""
    try:
        from roman_sim.world.ambiguity import place_ambiguity
    except ImportError as err:
        raise EvaluationError(f"place ambiguity is not available: {err}") from None
    return lambda center_xy: float(place_ambiguity(truth, center_xy, radius_m=radius_m))


def _true_pose(s: Submap) -> NDArray[np.float64]:
    if s.truth is None:
        raise EvaluationError(f"submap {s.name}: no ground truth (was it stripped with public()?)")
    return np.asarray(s.truth.T_world_submap, dtype=np.float64)


def _object_ids(s: Submap) -> set[int]:
    ids = np.asarray(s.truth.object_ids if s.truth is not None else [], dtype=np.int64)
    return {int(i) for i in ids if i >= 0}


def overlap_fraction(a: Submap, b: Submap) -> float:
    """Shared true object ids over the smaller id set; NaN when either set is empty."""
    ia, ib = _object_ids(a), _object_ids(b)
    if not ia or not ib:
        return float("nan")
    return len(ia & ib) / min(len(ia), len(ib))


def pair_truth(
    a: Submap,
    b: Submap,
    ambiguity_fn: AmbiguityFn | None = None,
    relevant_dist_m: float = RELEVANT_DIST_M,
) -> PairTruth:
    """Ground truth of the pair ``(a, b)``.

    Args:
        a, b: submaps with truth.
        ambiguity_fn: optional ground-truth ambiguity of a place, called with the (2,)
            midpoint of the two true centres; NaN when not given.
        relevant_dist_m: relevance threshold on the centre distance.

    Raises:
        EvaluationError: a submap has no truth.
    """
    T_wa, T_wb = _true_pose(a), _true_pose(b)
    T_ab = inv_T(T_wa) @ T_wb
    dist = float(np.linalg.norm(T_wb[:3, 3] - T_wa[:3, 3]))
    amb = float("nan")
    if ambiguity_fn is not None:
        amb = float(ambiguity_fn(0.5 * (T_wa[:2, 3] + T_wb[:2, 3])))
    return PairTruth(
        a=a.name,
        b=b.name,
        robot_a=a.robot,
        robot_b=b.robot,
        index_a=int(a.index),
        index_b=int(b.index),
        T_a_b_true=T_ab,
        center_dist_m=dist,
        heading_diff_deg=float(abs(np.degrees(yaw_of(T_ab)))),
        overlap=overlap_fraction(a, b),
        ambiguity=amb,
        relevant=bool(dist <= relevant_dist_m),
        kind="inter" if a.robot != b.robot else "intra",
    )


def _keep(a: Submap, b: Submap, intra_min_gap: int, max_dist: float | None, relevant: float) -> bool:
    if a.robot == b.robot and abs(a.index - b.index) < intra_min_gap:
        return False
    if max_dist is None:
        return True
    dist = float(np.linalg.norm(_true_pose(a)[:3, 3] - _true_pose(b)[:3, 3]))
    return dist <= max(max_dist, relevant)


def enumerate_pairs(
    submaps: list[Submap],
    intra_min_gap: int = INTRA_MIN_GAP,
    max_center_dist_m: float | None = None,
    relevant_dist_m: float = RELEVANT_DIST_M,
) -> list[tuple[Submap, Submap]]:
    """The submap pairs to evaluate, in a deterministic order.

    Submaps are sorted by (robot, index); each unordered pair appears once, with the
    earlier submap as ``a``.

    Args:
        submaps: submaps of all robots (with truth when ``max_center_dist_m`` is set).
        intra_min_gap: smallest index difference of an intra-robot pair (>= 1).
        max_center_dist_m: keep only pairs whose true centres are this close (relevant
            pairs are always kept); None keeps all.
        relevant_dist_m: relevance threshold (pairs within it are never dropped).

    Raises:
        EvaluationError: bad arguments or duplicate submap names.
    """
    if intra_min_gap < 1:
        raise EvaluationError(f"intra_min_gap must be >= 1, got {intra_min_gap}")
    if max_center_dist_m is not None and max_center_dist_m < 0:
        raise EvaluationError(f"max_center_dist_m must be >= 0, got {max_center_dist_m}")
    ordered = sorted(submaps, key=lambda s: (s.robot, s.index))
    names = [s.name for s in ordered]
    if len(set(names)) != len(names):
        raise EvaluationError("duplicate submap names (robot/index) in the evaluated submaps")
    pairs = [
        (a, b)
        for a, b in combinations(ordered, 2)
        if _keep(a, b, intra_min_gap, max_center_dist_m, relevant_dist_m)
    ]
    log.debug("%d pairs from %d submaps", len(pairs), len(ordered))
    return pairs


def truths_for_pairs(
    pairs: list[tuple[Submap, Submap]],
    ambiguity_fn: AmbiguityFn | None = None,
    relevant_dist_m: float = RELEVANT_DIST_M,
) -> list[PairTruth]:
    """``pair_truth`` of every pair."""
    return [pair_truth(a, b, ambiguity_fn, relevant_dist_m) for a, b in pairs]
