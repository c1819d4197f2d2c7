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

import numpy as np

from roman_sim.evaluation.atetable import FITS, Fit
from roman_sim.posegraph import LoopClosure

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


class ClosureJSON(TypedDict):
    """A loop closure and its weight in ``posegraph_estimates.json``."""

    robot_a: str
    submap_a: int
    robot_b: str
    submap_b: int
    T_a_b: list[list[float]]
    n_associations: int
    sigma_m: float | None
    sigma_deg: float | None
    source: str
    weight: float | None


def _closure_json(c: LoopClosure, w: float | None) -> ClosureJSON:
    return {
        "robot_a": c.robot_a,
        "submap_a": int(c.submap_a),
        "robot_b": c.robot_b,
        "submap_b": int(c.submap_b),
        "T_a_b": np.asarray(c.T_a_b, dtype=np.float64).tolist(),
        "n_associations": int(c.n_associations),
        "sigma_m": c.sigma_m,
        "sigma_deg": c.sigma_deg,
        "source": c.source,
        "weight": w,
    }


def _closure_from_json(d: ClosureJSON) -> tuple[LoopClosure, float | None]:
    c = LoopClosure(
        str(d["robot_a"]),
        int(d["submap_a"]),
        str(d["robot_b"]),
        int(d["submap_b"]),
        np.asarray(d["T_a_b"], dtype=np.float64),
        int(d["n_associations"]),
        None if d["sigma_m"] is None else float(d["sigma_m"]),
        None if d["sigma_deg"] is None else float(d["sigma_deg"]),
        str(d["source"]),
    )
    return c, None if d["weight"] is None else float(d["weight"])


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
