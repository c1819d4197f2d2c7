"""Evaluation settings: which pairs are scored, which should align, what counts as correct.

- **Pairs**: every inter-robot pair and every intra-robot pair at least ``intra_min_gap``
  submaps apart is aligned and scored. ``max_pair_dist_m`` is an explicit cap (true centre
  distance; the report names it and the number of pairs it skipped); relevant pairs are
  never skipped.
- **Relevance** (``relevance``): ``distance``, the true submap centres within
  ``relevant_dist_m`` (the paper's 10 m), or ``shared_objects``, at least
  ``min_shared_objects`` true objects in both submaps (3 by default: the fewest
  correspondences that fix a transform).
- **Correct**: rotation error within ``rot_tol_deg`` and translation error within
  ``trans_tol_m`` (5 deg / 1 m).
- **Intervals**: recalls come with a Wilson interval at ``interval_level``; a bin with
  fewer than ``min_relevant`` relevant pairs is marked as too small to measure.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal, NamedTuple

from pydantic import Field, model_validator

from roman_sim.core.config import StrictModel

Relevance = Literal["distance", "shared_objects"]


def _increasing(edges: list[float], name: str) -> None:
    if len(edges) < 2 or any(b <= a for a, b in zip(edges, edges[1:])):
        raise ValueError(f"{name} must hold at least 2 strictly increasing edges")


class EvalConfig(StrictModel):
    """Evaluation settings (pair selection, relevance, success thresholds, k sweep, bins, intervals)."""

    relevance: Relevance = Field(
        "distance",
        description="distance: centres within relevant_dist_m; "
        "shared_objects: at least min_shared_objects true objects in common",
    )
    relevant_dist_m: float = Field(10.0, gt=0, description="relevance by distance: true centres within this")
    min_shared_objects: int = Field(3, ge=1, description="relevance by shared objects: at least this many")
    rot_tol_deg: float = Field(5.0, gt=0, le=180, description="correct: rotation error within this")
    trans_tol_m: float = Field(1.0, gt=0, description="correct: translation error within this")
    k_min: int = Field(0, ge=0, description="smallest association count threshold of the sweep")
    k_max: int = Field(30, ge=0, le=10000, description="largest association count threshold")
    heading_bins_deg: list[float] = Field(default_factory=lambda: [0.0, 60.0, 120.0, 180.0])
    fine_heading_bin_deg: float = Field(30.0, gt=0, le=180)
    ambiguity_bins: list[float] = Field(default_factory=lambda: [0.0, 0.25, 0.5, 0.75, 1.0])
    intra_min_gap: int = Field(2, ge=1, description="smallest index gap of intra-robot pairs")
    max_pair_dist_m: float | None = Field(
        None,
        ge=0,
        description="distance cap: pairs whose true centres are "
        "farther apart are not aligned (relevant pairs are kept); None: every pair",
    )
    min_relevant: int = Field(5, ge=1, description="bins with fewer relevant pairs are marked, not measured")
    interval_level: float = Field(0.95, gt=0, lt=1, description="confidence level of the Wilson intervals")

    @model_validator(mode="after")
    def _check(self) -> "EvalConfig":
        if self.k_max < self.k_min:
            raise ValueError(f"k_max ({self.k_max}) must be >= k_min ({self.k_min})")
        _increasing(self.heading_bins_deg, "heading_bins_deg")
        _increasing(self.ambiguity_bins, "ambiguity_bins")
        if self.heading_bins_deg[0] < 0 or self.heading_bins_deg[-1] > 180:
            raise ValueError("heading_bins_deg must lie within [0, 180]")
        return self

    def k_values(self) -> list[int]:
        """The swept thresholds ``k_min..k_max``."""
        return list(range(self.k_min, self.k_max + 1))

    def is_relevant(self, center_dist_m: float, shared_objects: int) -> bool:
        """Whether a pair with these true properties should align (by ``relevance``)."""
        return RELEVANCE[self.relevance].test(self, center_dist_m, shared_objects)

    def describe_relevance(self) -> str:
        """The relevance criterion in words (for reports)."""
        return RELEVANCE[self.relevance].text(self)

    def describe_success(self) -> str:
        """The success thresholds in words."""
        return f"rotation error <= {self.rot_tol_deg:g} deg and translation error <= {self.trans_tol_m:g} m"


class Criterion(NamedTuple):
    """A relevance criterion: the test on (config, true centre distance, shared objects) and its wording."""

    test: Callable[[EvalConfig, float, int], bool]
    text: Callable[[EvalConfig], str]


#: ``relevance`` name -> criterion.
RELEVANCE: dict[str, Criterion] = {
    "distance": Criterion(
        lambda c, dist, shared: bool(dist <= c.relevant_dist_m),
        lambda c: f"true submap centres within {c.relevant_dist_m:g} m",
    ),
    "shared_objects": Criterion(
        lambda c, dist, shared: bool(shared >= c.min_shared_objects),
        lambda c: f"at least {c.min_shared_objects} true objects in both submaps",
    ),
}
