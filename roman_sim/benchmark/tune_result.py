"""``tune.json``: the result of ``roman-sim tune`` as typed records.

One ``TuneResult`` per folder: what was tuned (source, the suite level when one, method,
overrides, target precision,
the parameter grid), the worlds with their kilometres, one ``TuneConfig`` per config
(aligner and gating setting at thresholds chosen on other worlds: held-out figures, time per
pair, whether it is on the Pareto front), the held-out figures of the whole choice made
leaving each world out (``TuneHeldOut``: pooled, per world, and the precision interval of
one new world) and the recommended setting (``TuneRecommended``,
None when no setting qualifies under the rule on the calibration worlds) with the spread of its
precision from world to world (``TuneSpread``).

The held-out figures of a config and of the nested choice are a level's
``HeldOutFigures`` plus the false loop closures per km, in the same object.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from roman_sim.benchmark.board_records import HeldOutFigures
from roman_sim.core.records import OMIT_NONE, read_record, write_record

TUNE_SCHEMA = "roman_sim.tune/2"

#: A config's parameter values: name -> value (gating parameters as ``gating.<name>``).
Values = dict[str, int | float]


@dataclass(frozen=True, kw_only=True)
class TunedFigures(HeldOutFigures):
    """Held-out figures (``HeldOutFigures``) and the false loop closures per km driven."""

    false_per_km: float


@dataclass(frozen=True, kw_only=True)
class TuneConfig(TunedFigures):
    """One config at thresholds chosen on other worlds (per held-out world its threshold, None: none reached)."""

    id: str
    values: Values
    thresholds: dict[str, int | None]
    time_per_pair_s: float | None
    on_front: bool


@dataclass(frozen=True)
class TuneChoice:
    """The setting chosen without one world: a config and its threshold."""

    config: str
    threshold: int


@dataclass(frozen=True)
class TuneWorldHeldOut:
    """One world scored at the setting chosen on the others: its counts, precision and that ratio's Wilson interval."""

    hits: int
    false_positives: int
    precision: float | None
    precision_wilson: list[float] | None


@dataclass(frozen=True, kw_only=True)
class TuneHeldOut(TunedFigures):
    """The whole choice made leaving each world out.

    Attributes:
        chosen: per world its choice (None: none reached the target).
        per_world: per world its held-out counts and precision.
        precision_new_world: the precision interval of one new world: the hull of every world's
            Wilson interval and the pooled world-bootstrap interval (None: nothing accepted).
    """

    chosen: dict[str, TuneChoice | None]
    per_world: dict[str, TuneWorldHeldOut]
    precision_new_world: list[float] | None


@dataclass(frozen=True)
class TuneSpread:
    """How a setting's precision spreads over the calibration worlds (``benchmark.world_spread``): each world's
    precision a draw of Beta(a, b), fitted on ``worlds`` worlds; for a new world its expected precision
    (``mean``), the share of worlds at or above the target and within the slack of it, and the central interval
    holding 95 % of worlds."""

    a: float
    b: float
    worlds: int
    mean: float
    share_at_target: float
    share_within_slack: float
    interval: list[float]


@dataclass(frozen=True)
class TuneRecommended:
    """The setting chosen on every world, with its pooled figures on them and the spread of its precision over
    them (None, left out: fewer than two worlds accepted a pair)."""

    config: str
    values: Values
    threshold: int
    calibration_recall: float
    calibration_false_per_km: float
    time_per_pair_s: float | None
    spread: TuneSpread | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class TuneWorldKm:
    """A world of the tune and the kilometres its robots drove."""

    id: str
    km: float


@dataclass(frozen=True)
class TuneResult:
    """``tune.json`` (see the module docstring); ``level``: the suite level tuned (None, left out: every world
    of the source)."""

    source: str
    method: str
    overrides: list[str]
    target_precision: float
    parameters: dict[str, list[int | float]]
    worlds: list[TuneWorldKm]
    configs: list[TuneConfig]
    held_out: TuneHeldOut
    recommended: TuneRecommended | None
    level: str | None = field(default=None, metadata=OMIT_NONE)
    rule: str | None = field(default=None, metadata=OMIT_NONE)

    def config(self, cid: str) -> TuneConfig:
        """The config ``cid`` (KeyError when the tune has none of that id)."""
        for c in self.configs:
            if c.id == cid:
                return c
        raise KeyError(cid)


def write_tune(path: str | Path, result: TuneResult) -> Path:
    """Atomically write ``result`` to ``path`` (sorted keys, with its schema)."""
    return write_record(path, result, schema=TUNE_SCHEMA)


def read_tune(path: str | Path) -> TuneResult:
    """The ``TuneResult`` in ``path`` (RecordError names the file and the field when it does not match)."""
    return read_record(path, TuneResult, schema=TUNE_SCHEMA)


__all__ = [
    "TUNE_SCHEMA",
    "TuneChoice",
    "TuneConfig",
    "TuneHeldOut",
    "TuneRecommended",
    "TuneResult",
    "TuneSpread",
    "TuneWorldHeldOut",
    "TuneWorldKm",
    "TunedFigures",
    "read_tune",
    "write_tune",
]
