"""The pose graph's estimates besides the trajectories: what each variant is, each graph's closures and weights.

``posegraph_estimates.json`` holds, per trajectory variant in table order, its description,
its fit to the truth, the variant whose trajectory files it is scored from, and (for a pose
graph) every loop closure it was given with its GNC weight (None: not used by the graph);
plus the stage's notes. The trajectories themselves are the TUM files under
``trajectories/``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TypedDict

from roman_sim.evaluation.atetable import FITS, Fit
from roman_sim.posegraph import LoopClosure
from roman_sim.posegraph.types import LoopClosureJSON

ESTIMATES_JSON = "posegraph_estimates.json"
ESTIMATES_SCHEMA = "roman_sim.posegraph_estimates/1"


@dataclass(frozen=True)
class GraphInfo:
    """What one pose graph used: closures given, closures above the threshold, GNC inliers,
    robots no closure chain ties to the first robot."""

    closures: int
    closures_used: int
    inliers: int
    unconnected: list[str]


@dataclass
class Variant:
    """One trajectory variant: what it is, how it is fitted to the truth, where its trajectories are.

    Attributes:
        description: what the variant is (the ATE table's text).
        fit: ``joint`` or ``per_robot`` (``roman_sim.evaluation.atetable``).
        source: the variant whose trajectories it is scored from (``odometry_no_prior``
            uses ``odometry``'s).
        closures: the loop closures its pose graph was given (none for odometry).
        weights: per closure, its GNC weight (about 1 inlier, about 0 outlier), or None when
            the graph did not use it (below the association threshold or degenerate).
    """

    description: str
    fit: Fit
    source: str
    closures: list[LoopClosure] = field(default_factory=list)
    weights: list[float | None] = field(default_factory=list)


class ClosureJSON(LoopClosureJSON):
    """A loop closure and its weight in ``posegraph_estimates.json``."""

    weight: float | None


def _closure_json(c: LoopClosure, w: float | None) -> ClosureJSON:
    return {**c.to_json(), "weight": w}


def _closure_from_json(d: ClosureJSON) -> tuple[LoopClosure, float | None]:
    return LoopClosure.from_json(d), None if d["weight"] is None else float(d["weight"])


class VariantJSON(TypedDict):
    """A trajectory variant in ``posegraph_estimates.json``."""

    name: str
    description: str
    fit: Fit
    source: str
    closures: list[ClosureJSON]


def variant_json(name: str, v: Variant) -> VariantJSON:
    """A variant as its entry of ``posegraph_estimates.json``."""
    closures = [_closure_json(c, w) for c, w in zip(v.closures, v.weights)]
    return {"name": name, "description": v.description, "fit": v.fit, "source": v.source, "closures": closures}


def variant_from_json(d: VariantJSON) -> tuple[str, Variant]:
    """Inverse of ``variant_json`` (ValueError for an unknown fit)."""
    if d["fit"] not in FITS:
        raise ValueError(f"fit {d['fit']!r}")
    pairs = [_closure_from_json(c) for c in d["closures"]]
    return str(d["name"]), Variant(
        str(d["description"]), d["fit"], str(d["source"]), [c for c, _ in pairs], [w for _, w in pairs]
    )
