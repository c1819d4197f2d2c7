"""The benchmark leaderboard as typed records (what ``leaderboard.json`` holds).

A ``Leaderboard`` has one ``BoardLevel`` per ambiguity level; a finished level has one
``BoardCell`` per heading bin and one over all bins (``overall``), each with, per method, its
operating points and its ranks by interval. ``read_leaderboard`` / ``write_leaderboard_json``
are the only places the file is parsed or written (``core.records``: every field checked).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.benchmark.board_curves import LevelCurves
from roman_sim.benchmark.ranking import Rank
from roman_sim.core.records import OMIT_NONE, read_record, write_record
from roman_sim.evaluation.operating_points import OperatingPoint

LEADERBOARD_SCHEMA = "roman_sim.leaderboard/2"


@dataclass(frozen=True)
class BoardCell:
    """One cell of a level (a heading bin, or ``all``): per method its operating points and ranks.

    Attributes:
        heading: the bin label (``"150-180"``) or ``"all"``.
        n_pairs, n_relevant: cross-robot pairs scored and relevant in the cell.
        methods: per method, per operating point name (``POINT_NAMES``) the point (None when
            the method has none there).
        ranks: per ranked operating point, per method its rank by interval.
        max_half_width: the widest recall interval half-width over methods and points.
    """

    heading: str
    n_pairs: int
    n_relevant: int
    methods: dict[str, dict[str, OperatingPoint | None]]
    ranks: dict[str, dict[str, Rank]]
    max_half_width: float | None

    def point(self, method: str, name: str) -> OperatingPoint | None:
        """``method``'s operating point ``name`` in this cell (None when absent)."""
        return self.methods.get(method, {}).get(name)


@dataclass(frozen=True)
class HeldOutFigures:
    """One method's held-out figures in one heading bin of a level's deployable point.

    Attributes:
        hits, false_positives, n_relevant: held-out counts pooled over the level's worlds.
        recall, recall_wilson, recall_worlds: hits / relevant, its pooled Wilson interval and its
            world-bootstrap interval (None without relevant pairs).
        precision, precision_worlds: hits / (hits + false positives) and its world-bootstrap
            interval (None without a positive).
        transfers: whether the precision is within the slack of the target (true when nothing was accepted).
    """

    hits: int
    false_positives: int
    n_relevant: int
    recall: float | None
    recall_wilson: list[float] | None
    recall_worlds: list[float] | None
    precision: float | None
    precision_worlds: list[float] | None
    transfers: bool


@dataclass(frozen=True)
class PairVerdict:
    """Two methods compared in one heading bin of a level: the paired difference of held-out recall.

    Attributes:
        a, b: the methods (in the board's order).
        verdict: ``a ahead``, ``b ahead``, ``no difference shown`` or ``too few hits``
            (``roman_sim.evaluation.paired_worlds``).
        diff: held-out recall of ``a`` less that of ``b`` (same worlds, same relevant pairs).
        p_value: the exact two-sided sign-flip p-value over worlds.
        power: the power to detect a true difference of the level's effect size.
        worlds_for_power: worlds that power 0.8 for that effect needs at this spread.
        detectable: the smallest true difference the board's worlds detect with power 0.8 (None: a board
            written before it was kept).
    """

    a: str
    b: str
    verdict: str
    diff: float
    p_value: float
    power: float
    worlds_for_power: int
    detectable: float | None = field(default=None, metadata=OMIT_NONE)

    def winner(self) -> str | None:
        """The method ahead (None: no difference shown, or too few hits)."""
        return self.a if self.verdict == "a ahead" else self.b if self.verdict == "b ahead" else None

    def says(self, effect: float) -> str:
        """The verdict in words, with the method ahead or the power for ``effect``."""
        if self.verdict == "too few hits":
            return "too few hits"
        if self.winner() is not None:
            return f"{self.winner()} ahead"
        if self.power >= 0.8:
            return f"no difference shown with power 0.8 for {effect:g}"
        seen = "" if self.detectable is None else f", 0.8 for {self.detectable:.2f}"
        return (
            f"no difference shown (power {self.power:.2f} for {effect:g}{seen}; {self.worlds_for_power} worlds for 0.8)"
        )


@dataclass(frozen=True)
class DeployableCell:
    """One heading bin (or ``all``) of a deployable point: per method its held-out figures and rank.

    Attributes:
        heading: the bin label or ``all``.
        methods: per method its held-out figures.
        ranks: per method above the floor its rank: 1 + the methods a paired verdict puts ahead of it.
        max_half_width: the widest world-bootstrap recall half-width over the methods above the floor.
        verdicts: one paired verdict per two methods.
        floor: per method below the floor, ``too few hits to rank (h in n)``.
    """

    heading: str
    methods: dict[str, HeldOutFigures]
    ranks: dict[str, Rank]
    max_half_width: float | None
    verdicts: list[PairVerdict] = field(default_factory=list)
    floor: dict[str, str] = field(default_factory=dict)

    def order(self) -> list[tuple[str, HeldOutFigures, Rank]]:
        """(method, figures, rank) of the ranked methods, best first (rank, then recall, then name)."""
        got = [(m, c, self.ranks[m]) for m, c in self.methods.items() if m in self.ranks]
        return sorted(got, key=lambda x: (x[2].rank, -(x[1].recall or 0.0), x[0]))

    def verdict(self, a: str, b: str) -> PairVerdict | None:
        """The verdict of ``a`` against ``b`` (in either order as stored), None when not compared."""
        return next((v for v in self.verdicts if {v.a, v.b} == {a, b}), None)


@dataclass(frozen=True)
class PrecisionSpread:
    """How one method's held-out precision spreads from world to world (``benchmark.world_spread``): each held-out
    world's precision a draw of Beta(a, b), fitted on its held-out hits out of its accepted pairs over all headings.

    Attributes:
        a, b: the fitted beta distribution.
        worlds: the worlds that accepted a pair (those the fit rests on).
        level: the share of new worlds the interval holds.
        interval: the one-new-world interval: the central interval of a new world's precision holding ``level`` of
            new worlds. A new world that accepts n pairs has its hits within ``WorldSpread.hits_interval(n)``
            (its own few pairs add binomial noise): what ``roman-sim benchmark check`` tests fresh worlds against.
    """

    a: float
    b: float
    worlds: int
    level: float
    interval: list[float]


@dataclass(frozen=True)
class Deployable:
    """A level's deployable point (``roman_sim.benchmark.deployable``): thresholds chosen on other worlds.

    A level with fewer than two worlds has only ``note`` (why there are no held-out figures).

    Attributes:
        target_precision: the precision the thresholds are chosen for.
        worlds: the level's worlds (benchmark cells).
        note: why there are no held-out figures (None when there are).
        thresholds: per method, per held-out world the threshold chosen on the others (None: none reached it):
            an int on the association count, a float on a method's named score (``Leaderboard.score``).
        deployed: per method the threshold chosen on every world of the level: the one a new world
            is run at (``roman-sim benchmark check``).
        spread: per method the spread of its held-out precision over the level's worlds and the one-new-world
            interval it states (None: fewer than two worlds accepted a pair).
        min_hits: held-out hits below which a method is a floor in a bin (not ranked, no bound).
        effect: the recall difference the paired verdicts state their power for.
        transfers: per method, whether its held-out precision over all headings transfers.
        bins: one cell per heading bin.
        overall: the cell over every heading.
    """

    target_precision: float
    worlds: list[str]
    note: str | None = field(default=None, metadata=OMIT_NONE)
    thresholds: dict[str, dict[str, int | float | None]] | None = field(default=None, metadata=OMIT_NONE)
    deployed: dict[str, int | float | None] | None = field(default=None, metadata=OMIT_NONE)
    spread: dict[str, PrecisionSpread | None] | None = field(default=None, metadata=OMIT_NONE)
    min_hits: int | None = field(default=None, metadata=OMIT_NONE)
    effect: float | None = field(default=None, metadata=OMIT_NONE)
    transfers: dict[str, bool] | None = field(default=None, metadata=OMIT_NONE)
    bins: list[DeployableCell] | None = field(default=None, metadata=OMIT_NONE)
    overall: DeployableCell | None = field(default=None, metadata=OMIT_NONE)

    def cells(self) -> list[DeployableCell]:
        """The heading-bin cells, then the overall one."""
        return [*(self.bins or []), *([self.overall] if self.overall is not None else [])]


@dataclass(frozen=True)
class BoardLevel:
    """One ambiguity level: its cells (absent until a cell of the level finished).

    Attributes:
        name, knob: the level's name and the scenario knob it sets.
        cells: the benchmark cells (scenario runs) pooled into the level.
        acceptance_k: the pose graph's acceptance threshold of those runs.
        ambiguity_index: mean measured ambiguity of the level's cross-robot pairs.
        interval_level: the confidence level of the intervals.
        overall: the cell over every heading bin.
        bins: one cell per heading bin.
        deployable: the level's deployable point (``roman_sim.benchmark.deployable``: held-out
            thresholds per world, recall and precision, ranks), as computed there.
        curves: per method its precision-recall curve on the board's score with world intervals and the
            area under it (``roman_sim.benchmark.board_curves``; None with fewer than two worlds).
    """

    name: str
    knob: float
    cells: list[str]
    acceptance_k: int | None
    ambiguity_index: float | None = field(default=None, metadata=OMIT_NONE)
    interval_level: float | None = field(default=None, metadata=OMIT_NONE)
    overall: BoardCell | None = field(default=None, metadata=OMIT_NONE)
    bins: list[BoardCell] = field(default_factory=list)
    deployable: Deployable | None = field(default=None, metadata=OMIT_NONE)
    curves: LevelCurves | None = field(default=None, metadata=OMIT_NONE)

    @property
    def finished(self) -> bool:
        """Whether a cell of the level finished (it has figures)."""
        return self.overall is not None

    def all_cells(self) -> list[BoardCell]:
        """The heading-bin cells, then the overall one."""
        return [*self.bins, *([self.overall] if self.overall is not None else [])]


@dataclass(frozen=True)
class MethodRuntime:
    """One method's alignment time per pair over the benchmark's cells (s).

    Attributes:
        n: pairs timed.
        mean_s: mean over every timed pair.
        cell_medians_s, cell_p10_s, cell_p90_s: per cell its median, 10th and 90th percentile.
    """

    n: int
    mean_s: float
    cell_medians_s: list[float]
    cell_p10_s: list[float | None]
    cell_p90_s: list[float]


@dataclass(frozen=True)
class Leaderboard:
    """A benchmark's leaderboard (``leaderboard.json``).

    Attributes:
        suite, description: the suite's name and description.
        methods: the methods scored, in the suite's order, by the label of their rows (a plug-in's
            class name).
        overrides: scenario overrides of every cell.
        heading_edges_deg: the heading bin edges.
        half_width_bound: widest interval half-width the suite promises.
        failed_cells: cells that did not finish, with why.
        levels: one entry per ambiguity level.
        bound_met: whether the pooled Wilson intervals of every bin's per-bin operating points meet the
            bound and every cell finished.
        runtime: per method its time per pair.
        target_precision: the precision the deployable point's thresholds are chosen for.
        deployable_bound_met: the headline bound: whether, at the deployable point, every level x heading
            bin has held-out figures whose widest world-bootstrap recall half-width over the methods above the
            floor is at most the bound, and every cell finished (``deployable_widths``); a bin where every
            method is below the floor holds no bound (``deployable_floors``: reported, not counted as met).
        plugins: per plug-in row its ``package.module:Class`` (None without plug-ins).
        score: the confidence score the deployable thresholds and the curves are on (``associations``, the
            association count, unless ``roman-sim benchmark --score`` named a method's own score).
    """

    suite: str
    description: str
    methods: list[str]
    overrides: list[str]
    heading_edges_deg: list[float]
    half_width_bound: float
    failed_cells: dict[str, str]
    levels: list[BoardLevel]
    bound_met: bool = False
    runtime: dict[str, MethodRuntime] = field(default_factory=dict)
    target_precision: float | None = field(default=None, metadata=OMIT_NONE)
    deployable_bound_met: bool = False
    plugins: dict[str, str] | None = field(default=None, metadata=OMIT_NONE)
    score: str = DEFAULT_SCORE

    def finished_levels(self) -> list[BoardLevel]:
        """The levels with figures."""
        return [e for e in self.levels if e.finished]

    def deployable_widths(self) -> dict[str, dict[str, float | None]]:
        """Per level, per heading bin the widest world-bootstrap half-width of held-out recall over methods
        (None where no method has relevant pairs); a level without held-out figures maps to ``{}``."""
        return {
            e.name: {}
            if e.deployable is None or e.deployable.bins is None
            else {c.heading: c.max_half_width for c in e.deployable.bins}
            for e in self.levels
        }

    def deployable_floors(self) -> list[tuple[str, str]]:
        """(level, heading bin) of every bin where each method is below the floor: nothing there is ranked, and
        no bound holds or fails (a floor is a finding, not a tie)."""
        return [
            (e.name, c.heading)
            for e in self.levels
            if e.deployable is not None and e.deployable.bins is not None
            for c in e.deployable.bins
            if c.methods and set(c.floor) == set(c.methods)
        ]

    def deployable_over(self) -> list[tuple[str, str, float | None]]:
        """(level, heading bin, widest half-width) of every bin over the bound or without an interval, floors aside."""
        floors = set(self.deployable_floors())
        return [
            (level, heading, w)
            for level, bins in self.deployable_widths().items()
            for heading, w in bins.items()
            if (level, heading) not in floors and (w is None or w > self.half_width_bound)
        ]

    def cells_of(self, method: str, point: str) -> dict[str, OperatingPoint]:
        """``{"<level>/<heading bin>": point}`` of ``method`` (``"<level>/all"`` too), where it has the point."""
        return {
            f"{e.name}/{c.heading}": p
            for e in self.levels
            for c in e.all_cells()
            if (p := c.point(method, point)) is not None
        }


def read_leaderboard(path: str | Path) -> Leaderboard:
    """``leaderboard.json`` as a ``Leaderboard`` (``RecordError`` naming the file and field when malformed)."""
    return read_record(path, Leaderboard, LEADERBOARD_SCHEMA)


def write_leaderboard_json(path: str | Path, board: Leaderboard) -> Path:
    """Atomically write ``leaderboard.json``."""
    return write_record(path, board, LEADERBOARD_SCHEMA)
