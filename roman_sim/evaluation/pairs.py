"""Submap pairs and their ground truth: relative pose, distance, heading, shared objects.

A pair ``(a, b)`` is described from a's side: ``T_a_b_true = inv(T_world_a) @ T_world_b``
with the gravity-aligned true submap poses, so an aligner's ``T_a_b`` is compared to it
directly. Which pairs are evaluated (``select_pairs``):

* every inter-robot pair (submaps of two different robots);
* intra-robot pairs whose submap indices differ by at least ``intra_min_gap`` (default 2:
  consecutive submaps of one robot share most of their segments by construction and say
  nothing about loop closure, so they are left out).

A distance cap (``EvalConfig.max_pair_dist_m``) is an explicit option: it skips pairs whose
true centres are farther apart (never a relevant pair) and the number skipped is reported.
A pair's place ambiguity is the mean of the ground-truth ambiguity at its two true centres
(computed once per submap).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import combinations
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import inv_T, yaw_of
from roman_sim.evaluation.assoc import shared_objects, true_correspondences
from roman_sim.evaluation.config import EvalConfig
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
        ambiguity: ground-truth ambiguity of the place (mean over the two centres), or NaN.
        relevant: whether the pair should align (``EvalConfig.is_relevant``).
        kind: ``"inter"`` (two robots) or ``"intra"`` (one robot, not neighbours in time).
        shared_objects: distinct true objects with a segment in both submaps.
        true_correspondences: segment correspondences available one-to-one
            (``assoc.true_correspondences``).
        ids_a, ids_b: majority object id per segment (None when not known, e.g. read back
            from ``pairs.csv``); used to score a method's associations.
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
    shared_objects: int = 0
    true_correspondences: int = 0
    ids_a: NDArray[np.int64] | None = field(default=None, repr=False, compare=False)
    ids_b: NDArray[np.int64] | None = field(default=None, repr=False, compare=False)


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


def _object_ids(s: Submap) -> NDArray[np.int64]:
    return np.asarray(s.truth.object_ids if s.truth is not None else [], dtype=np.int64).reshape(-1)


def overlap_fraction(a: Submap, b: Submap) -> float:
    """Shared true object ids over the smaller id set; NaN when either set is empty."""
    ia, ib = ({int(i) for i in _object_ids(s) if i >= 0} for s in (a, b))
    if not ia or not ib:
        return float("nan")
    return len(ia & ib) / min(len(ia), len(ib))


def center_distance(a: Submap, b: Submap) -> float:
    """Distance between the true submap centres (m)."""
    return float(np.linalg.norm(_true_pose(b)[:3, 3] - _true_pose(a)[:3, 3]))


def pair_truth(
    a: Submap,
    b: Submap,
    ambiguity_fn: AmbiguityFn | None = None,
    cfg: EvalConfig | None = None,
    ambiguity: float | None = None,
) -> PairTruth:
    """Ground truth of the pair ``(a, b)``.

    Args:
        a: a submap with truth.
        b: the other submap, with truth.
        ambiguity_fn: optional ground-truth ambiguity of a place, called with the (2,) true
            centre of each submap; the pair's is the mean. NaN when not given.
        cfg: relevance settings (defaults: centres within 10 m).
        ambiguity: the pair's ambiguity when already known (``ambiguity_fn`` is then unused).

    Raises:
        EvaluationError: a submap has no truth.
    """
    cfg = cfg or EvalConfig()
    T_wa, T_wb = _true_pose(a), _true_pose(b)
    T_ab = inv_T(T_wa) @ T_wb
    dist = float(np.linalg.norm(T_wb[:3, 3] - T_wa[:3, 3]))
    if ambiguity is None:
        ambiguity = float("nan")
        if ambiguity_fn is not None:
            ambiguity = 0.5 * (float(ambiguity_fn(T_wa[:2, 3])) + float(ambiguity_fn(T_wb[:2, 3])))
    ids_a, ids_b = _object_ids(a), _object_ids(b)
    shared = shared_objects(ids_a, ids_b)
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
        ambiguity=float(ambiguity),
        relevant=cfg.is_relevant(dist, shared),
        kind="inter" if a.robot != b.robot else "intra",
        shared_objects=shared,
        true_correspondences=true_correspondences(ids_a, ids_b),
        ids_a=ids_a,
        ids_b=ids_b,
    )


def _candidates(submaps: list[Submap], intra_min_gap: int) -> list[tuple[Submap, Submap]]:
    """Every pair in (robot, index) order, without intra-robot pairs closer than the gap."""
    if intra_min_gap < 1:
        raise EvaluationError(f"intra_min_gap must be >= 1, got {intra_min_gap}")
    ordered = sorted(submaps, key=lambda s: (s.robot, s.index))
    names = [s.name for s in ordered]
    if len(set(names)) != len(names):
        raise EvaluationError("duplicate submap names (robot/index) in the evaluated submaps")
    return [
        (a, b)
        for a, b in combinations(ordered, 2)
        if not (a.robot == b.robot and abs(a.index - b.index) < intra_min_gap)
    ]


@dataclass
class PairSelection:
    """The pairs to align and score, and how many a distance cap skipped.

    Attributes:
        pairs: the selected pairs, in a deterministic order.
        n_candidates: pairs before the cap (every inter-robot pair and intra-robot pair
            at least ``intra_min_gap`` apart).
        n_skipped: candidates the cap left out (0 without a cap).
        cap_m: the cap used (None: every candidate is scored).
    """

    pairs: list[tuple[Submap, Submap]]
    n_candidates: int
    n_skipped: int
    cap_m: float | None


def select_pairs(submaps: list[Submap], cfg: EvalConfig | None = None) -> PairSelection:
    """The pairs to evaluate under ``cfg`` (every candidate unless ``max_pair_dist_m`` is set).

    A capped selection keeps pairs whose true centres are within the cap and every relevant
    pair. Raises EvaluationError on a gap below 1 or duplicate submap names.
    """
    cfg = cfg or EvalConfig()
    cand = _candidates(submaps, cfg.intra_min_gap)
    cap = cfg.max_pair_dist_m
    if cap is None:
        return PairSelection(cand, len(cand), 0, None)
    keep = []
    for a, b in cand:
        dist = center_distance(a, b)
        if dist <= cap or cfg.is_relevant(dist, shared_objects(_object_ids(a), _object_ids(b))):
            keep.append((a, b))
    log.info("distance cap %.1f m: %d of %d pairs skipped", cap, len(cand) - len(keep), len(cand))
    return PairSelection(keep, len(cand), len(cand) - len(keep), cap)


def enumerate_pairs(
    submaps: list[Submap],
    intra_min_gap: int = INTRA_MIN_GAP,
    max_center_dist_m: float | None = None,
    relevant_dist_m: float = RELEVANT_DIST_M,
) -> list[tuple[Submap, Submap]]:
    """The submap pairs to evaluate, in a deterministic order (``select_pairs`` by distance).

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
    if max_center_dist_m is not None and max_center_dist_m < 0:
        raise EvaluationError(f"max_center_dist_m must be >= 0, got {max_center_dist_m}")
    if intra_min_gap < 1:
        raise EvaluationError(f"intra_min_gap must be >= 1, got {intra_min_gap}")
    cfg = EvalConfig(relevant_dist_m=relevant_dist_m, intra_min_gap=intra_min_gap, max_pair_dist_m=max_center_dist_m)
    return select_pairs(submaps, cfg).pairs


def truths_for_pairs(
    pairs: list[tuple[Submap, Submap]],
    ambiguity_fn: AmbiguityFn | None = None,
    cfg: EvalConfig | None = None,
) -> list[PairTruth]:
    """``pair_truth`` of every pair, the ambiguity computed once per submap."""
    amb: dict[str, float] = {}
    if ambiguity_fn is not None:
        for s in {s.name: s for p in pairs for s in p}.values():
            amb[s.name] = float(ambiguity_fn(_true_pose(s)[:2, 3]))
    return [pair_truth(a, b, cfg=cfg, ambiguity=0.5 * (amb[a.name] + amb[b.name]) if amb else None) for a, b in pairs]
