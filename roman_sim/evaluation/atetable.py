"""The ATE table: every trajectory variant of a run scored over the same robots.

A variant (odometry, a pose graph, ...) places some robots in its common frame and not
others: a pose graph ties a robot to the first robot only through inter-robot closures,
and a robot it never connects has no position there. Any placement the evaluation could
invent for such a robot (its true start pose, or the origin) would be borrowed from the
truth or arbitrary, so it is not scored; instead:

- each variant states the robots it placed (``connected``);
- ``common`` is the concatenated ATE over the robots *every* variant placed (the table's
  common robots), so the rows compare the same poses;
- ``all`` is the concatenated ATE over every robot, given only for variants that placed
  every robot (None otherwise: "not connected");
- per robot, each robot aligned on its own (None for a robot the variant did not place).

A variant's ``fit`` says how its trajectories are aligned to the truth: ``joint`` (one
SE(3) or 4-DoF fit of the concatenation, as evo's APE of a multi-robot trajectory) or
``per_robot`` (one fit per robot, the concatenated error pooled: for odometry whose start
poses are unknown). Each row is a ``TrajectoryVariant`` (which exist is decided in
``roman_sim.evaluation.variants``); adding one is one more entry in the ``variants`` dict.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from roman_sim.core.errors import EvaluationError
from roman_sim.core.records import OMIT_NONE, read_record, write_record
from roman_sim.core.trajectory import Trajectory
from roman_sim.evaluation.ate import AteResult, multi_robot_ate
from roman_sim.posegraph.types import LoopClosure

#: Schema tag of ``ate.json``.
ATE_SCHEMA = "roman_sim.ate/2"
Fit = Literal["joint", "per_robot"]
FITS: tuple[Fit, ...] = ("joint", "per_robot")
ALIGNMENTS = ("se3", "4dof")
#: Row keys for the concatenated trajectories (robot names may not take them).
COMMON, ALL = "common", "all"


@dataclass
class TrajectoryVariant:
    """One trajectory variant (a row of the ATE table).

    Attributes:
        description: what the variant is (the ATE table's text).
        fit: ``joint`` (one fit of the concatenated robots) or ``per_robot`` (one fit per
            robot), see the module docstring.
        source: the variant whose trajectories it is scored from (``odometry_no_prior``
            uses ``odometry``'s; a pose graph its own).
        closures: the loop closures its pose graph was given (none for odometry).
        weights: per closure, its GNC weight (about 1 inlier, about 0 outlier), or None when
            the graph did not use it (below the association threshold or degenerate); empty
            until the graph is solved.
        association_thresh: the acceptance threshold of its pose graph when it overrides the
            scenario's ``lc_association_thresh`` (not stored: it only matters for solving).
    """

    description: str
    fit: Fit = "joint"
    source: str = ""
    closures: list[LoopClosure] = field(default_factory=list)
    weights: list[float | None] = field(default_factory=list)
    association_thresh: int | None = field(default=None, compare=False)


@dataclass
class VariantAte:
    """One row of the ATE table.

    Attributes:
        description: what the variant is.
        fit: ``joint`` or ``per_robot`` (see the module docstring).
        connected: robots the variant placed in its common frame (scenario order).
        rmse: alignment -> ``common`` / ``all`` / robot name -> RMSE (m) or None.
        source: the variant whose trajectory files hold this row's trajectories.
    """

    description: str
    fit: Fit
    connected: list[str]
    rmse: dict[str, dict[str, float | None]] = field(default_factory=dict)
    source: str = ""


@dataclass
class AteRow:
    """One row of the ATE table as ``ate.json`` stores it: the variant's name and its ``VariantAte`` fields."""

    name: str
    description: str
    fit: Fit
    connected: list[str]
    rmse: dict[str, dict[str, float | None]]
    source: str


@dataclass
class AteRecord:
    """What ``ate.json`` holds: the table (rows in order) and the run's notes (absent in other ATE files)."""

    robots: list[str]
    common: list[str]
    variants: list[AteRow]
    notes: list[str] | None = field(default=None, metadata=OMIT_NONE)


@dataclass
class AteTable:
    """ATE RMSE (m) per trajectory variant, over the same robots in every row.

    Attributes:
        robots: every robot of the run (scenario order).
        common: robots every variant placed (what the ``common`` column covers).
        variants: variant name -> its row, in table order.
    """

    robots: list[str] = field(default_factory=list)
    common: list[str] = field(default_factory=list)
    variants: dict[str, VariantAte] = field(default_factory=dict)

    def rmse(self, variant: str, alignment: str = "se3", robot: str = COMMON) -> float | None:
        """One RMSE: ``robot`` is ``common`` (default), ``all`` or a robot name."""
        if variant not in self.variants:
            raise EvaluationError(f"ATE variant {variant!r} unknown (variants: {', '.join(self.variants) or 'none'})")
        table = self.variants[variant].rmse
        if alignment not in table:
            raise EvaluationError(f"ATE alignment {alignment!r} unknown (alignments: {', '.join(table)})")
        if robot not in table[alignment]:
            raise EvaluationError(f"ATE robot {robot!r} unknown (valid: {COMMON}, {ALL}, {', '.join(self.robots)})")
        return table[alignment][robot]

    def record(self, notes: list[str] | None = None) -> AteRecord:
        """The table as its ``ate.json`` record (variants as a list, so their order survives sorted keys)."""
        rows = [AteRow(k, v.description, v.fit, v.connected, v.rmse, v.source) for k, v in self.variants.items()]
        return AteRecord(self.robots, self.common, rows, notes)

    @classmethod
    def from_record(cls, rec: AteRecord) -> "AteTable":
        """Inverse of ``record`` (the notes are not part of the table)."""
        rows = {r.name: VariantAte(r.description, r.fit, r.connected, r.rmse, r.source) for r in rec.variants}
        return cls(rec.robots, rec.common, rows)


def write_ate(path: str | Path, table: AteTable, notes: list[str]) -> Path:
    """Atomically write ``ate.json``: the table and the run's notes."""
    return write_record(path, table.record(notes), ATE_SCHEMA)


def read_ate(path: str | Path) -> tuple[AteTable, list[str]]:
    """``ate.json``: the table and the notes (RecordError naming the file and the field if it is not one)."""
    rec = read_record(path, AteRecord, ATE_SCHEMA)
    return AteTable.from_record(rec), list(rec.notes or [])


def _pooled(results: list[AteResult]) -> float:
    """RMSE over the union of per-robot residuals: sqrt(sum n rmse^2 / sum n)."""
    n = sum(r.n for r in results)
    return math.sqrt(sum(r.n * r.rmse_m**2 for r in results) / n)


def _concatenated(
    est: Mapping[str, Trajectory], fit: Fit, truth: Mapping[str, Trajectory], robots: list[str], alignment: str
) -> float | None:
    """ATE of ``robots`` (all placed in ``est``) as one trajectory; None if empty or not computable."""
    if not robots:
        return None
    sub_est, sub_ref = {r: est[r] for r in robots}, {r: truth[r] for r in robots}
    res = multi_robot_ate(sub_est, sub_ref, alignment)  # type: ignore[arg-type]
    if any(res[r] is None for r in robots):
        return None
    if fit == "per_robot":
        return _pooled([res[r] for r in robots])  # type: ignore[misc]
    return None if res["all"] is None else res["all"].rmse_m


def ate_table(
    truth: Mapping[str, Trajectory],
    variants: Mapping[str, TrajectoryVariant],
    trajectories: Mapping[str, Mapping[str, Trajectory]],
    alignments: tuple[str, ...] = ALIGNMENTS,
) -> AteTable:
    """Score every variant against ``truth`` over the same robots (see the module docstring).

    Args:
        truth: robot -> true trajectory (its order is the table's robot order).
        variants: variant name -> variant (its fit and trajectory source), in table order.
        trajectories: trajectory source -> robot -> trajectory (placed robots only, in the
            source's common frame); a variant without a ``source`` is scored from its own name.
        alignments: ``se3`` and/or ``4dof``.

    Raises:
        EvaluationError: a variant's trajectories are missing or place a robot without
            truth, or a robot is named ``common`` or ``all``.
    """
    robots = list(truth)
    if {COMMON, ALL} & set(robots):
        raise EvaluationError(f"ATE table: a robot may not be named {COMMON!r} or {ALL!r}")
    sources = {name: v.source or name for name, v in variants.items()}
    for name, src in sources.items():
        if src not in trajectories:
            raise EvaluationError(f"ATE variant {name!r}: no trajectories {src!r}")
        extra = sorted(set(trajectories[src]) - set(robots))
        if extra:
            raise EvaluationError(f"ATE variant {name!r}: no true trajectory for {', '.join(extra)}")
    connected = {name: [r for r in robots if r in trajectories[src]] for name, src in sources.items()}
    common = [r for r in robots if all(r in c for c in connected.values())]
    table = AteTable(robots, common)
    for name, v in variants.items():
        est = trajectories[sources[name]]
        row = VariantAte(v.description, v.fit, connected[name], source=sources[name])
        for al in alignments:
            placed = connected[name]
            per = multi_robot_ate({r: est[r] for r in placed}, {r: truth[r] for r in placed}, al)  # type: ignore[arg-type]
            cells: dict[str, float | None] = {
                COMMON: _concatenated(est, v.fit, truth, common, al),
                ALL: _concatenated(est, v.fit, truth, robots, al) if placed == robots else None,
            }
            cells.update({r: (None if per.get(r) is None else per[r].rmse_m) for r in robots})  # type: ignore[union-attr]
            row.rmse[al] = cells
        table.variants[name] = row
    return table
