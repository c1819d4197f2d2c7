"""Operating points of a method's precision-recall sweep: where it would actually be run.

Max recall over the association threshold k is usually reached at k = 0, where every pair is
a positive and precision is a few percent; it says nothing about a usable setting. Next to
it every pair set and bin gets four points, each with its threshold, its counts and Wilson
intervals of recall (hits / relevant) and precision (TP / (TP + FP)):

- ``max_recall``: the most true positives over k; ``k`` is the *highest* threshold that keeps
  them (false positives only fall as k rises, so this is the best precision at max recall;
  with no hit at all, the lowest threshold);
- ``precision_90`` / ``precision_100``: the smallest k whose precision is at least 0.9 / 1
  (true positives only fall as k rises, so this is the most recall at that precision);
  when no threshold reaches it, recall is 0 (defined), ``k`` None and ``reached`` false;
- ``acceptance``: k = the pose graph's acceptance threshold (``lc_association_thresh``):
  the closures the pose graph would accept; absent when no threshold is given.

Thresholds are those of the sweep (``EvalConfig.k_values``) except the acceptance threshold,
which is used as given. Undefined values are None, never 0.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Literal

import numpy as np

from roman_sim.evaluation.intervals import Interval, wilson

#: Operating point name -> the precision it must reach (the others have no target).
TARGET_PRECISION = {"precision_90": Fraction(9, 10), "precision_100": Fraction(1)}
#: The name of an operating point.
PointName = Literal["max_recall", "precision_90", "precision_100", "acceptance"]
#: The operating points, in table order.
POINT_NAMES: tuple[PointName, ...] = ("max_recall", "precision_90", "precision_100", "acceptance")
#: How the points are named in tables.
POINT_LABELS = {
    "max_recall": "max recall",
    "precision_90": "recall at P>=0.9",
    "precision_100": "recall at P=1",
    "acceptance": "recall at acceptance",
}


@dataclass(frozen=True)
class OperatingPoint:
    """Recall and precision of one method at one threshold.

    Attributes:
        k: the threshold (None: no threshold meets the point's condition).
        reached: whether a threshold meets it (always true for max recall and acceptance).
        hits: true positives at ``k`` (0 when not reached).
        n_relevant: relevant pairs (the recall's denominator).
        false_positives: positives that are not correct at ``k``.
        recall, recall_ci: hits / n_relevant and its Wilson interval (None without relevant pairs).
        precision, precision_ci: hits / (hits + false_positives) and its Wilson interval (None
            without a positive at ``k``).
    """

    k: int | None
    reached: bool
    hits: int
    n_relevant: int
    false_positives: int
    recall: float | None
    recall_ci: Interval
    precision: float | None
    precision_ci: Interval


#: Operating point name -> the point (None: not computed, e.g. acceptance without a threshold).
OperatingPoints = dict[str, OperatingPoint | None]


def point_at(k: int | None, tp: int, fp: int, n_relevant: int, level: float, reached: bool = True) -> OperatingPoint:
    """The operating point with ``tp`` true and ``fp`` false positives at threshold ``k``."""
    if not reached:
        tp, fp = 0, 0
    pos = tp + fp
    return OperatingPoint(
        k=k,
        reached=reached,
        hits=tp,
        n_relevant=n_relevant,
        false_positives=fp,
        recall=tp / n_relevant if n_relevant else None,
        recall_ci=wilson(tp, n_relevant, level),
        precision=tp / pos if pos else None,
        precision_ci=wilson(tp, pos, level),
    )


def sweep_points(
    k: np.ndarray, tp: np.ndarray, fp: np.ndarray, n_relevant: int, level: float
) -> dict[str, OperatingPoint]:
    """Max recall and the target-precision points of a sweep (arrays over increasing ``k``)."""
    out: dict[str, OperatingPoint] = {}
    if len(k) == 0:
        return {name: point_at(None, 0, 0, n_relevant, level, reached=False) for name in POINT_NAMES[:3]}
    best = int(tp.max())
    i = int(np.flatnonzero(tp == best)[-1]) if best else 0  # no hit at all: the lowest threshold
    out["max_recall"] = point_at(int(k[i]), best, int(fp[i]), n_relevant, level)
    pos = tp + fp
    for name, target in TARGET_PRECISION.items():
        # in integers: tp / pos >= p / q  <=>  tp * q >= p * pos (0.9 * 30 is not 27 in floats)
        ok = np.flatnonzero((pos > 0) & (tp * target.denominator >= target.numerator * pos))
        if len(ok):
            j = int(ok[0])
            out[name] = point_at(int(k[j]), int(tp[j]), int(fp[j]), n_relevant, level)
        else:
            out[name] = point_at(None, 0, 0, n_relevant, level, reached=False)
    return out


def strip_absent_points(stored: dict[str, Any], recomputed: dict[str, Any]) -> bool:
    """Drop the operating points from ``recomputed`` when ``stored`` (a metrics file) predates them.

    Returns whether anything was dropped, so a verification can say the points were not compared.
    """
    if "acceptance_k" in stored:
        return False

    def strip(node: Any) -> None:
        if isinstance(node, dict):
            node.pop("operating_points", None)
            for v in node.values():
                strip(v)
        elif isinstance(node, list):
            for v in node:
                strip(v)

    recomputed.pop("acceptance_k", None)
    strip(recomputed)
    return True
