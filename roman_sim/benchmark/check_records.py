"""``check.json``: a board checked on fresh worlds (``roman_sim.benchmark.check``), as typed records.

``BoardCheck`` holds one ``LevelCheck`` per level of the board: per method its precision on the fresh
worlds at the deployed threshold (``PrecisionCheck``, each world against the board's one-new-world
interval: ``FreshWorld``) and per paired verdict the board states its fate there (``VerdictCheck``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from roman_sim.core.records import OMIT_NONE, read_record

CHECK_SCHEMA = "roman_sim.benchmark_check/1"


@dataclass(frozen=True)
class FreshWorld:
    """One fresh world at a method's deployed threshold, against the board's one-new-world interval.

    Attributes:
        world: the fresh cell.
        hits, accepted: its hits and accepted pairs (hits and false positives) over all headings.
        precision: hits / accepted (None: nothing accepted).
        hits_interval: the interval of hits the board's fit gives a world accepting ``accepted`` pairs
            (None: nothing accepted, or the board states no interval).
        inside: whether ``hits`` lies in it (None: not tested).
    """

    world: str
    hits: int
    accepted: int
    precision: float | None
    hits_interval: list[int] | None
    inside: bool | None


@dataclass(frozen=True)
class PrecisionCheck:
    """One method's precision on a level's fresh worlds at its deployed threshold.

    Attributes:
        method: the method's row.
        k: the deployed threshold (None: none reached the target on the board's worlds; nothing is accepted).
        hits, false_positives: pooled over the fresh worlds, all headings.
        precision: pooled hits / (hits + false positives) (None: nothing accepted).
        target_held: whether that precision is within the slack of the target (as the board flags it).
        stated: the board's one-new-world precision interval (None: it states none).
        worlds: each fresh world against the board's interval.
    """

    method: str
    k: int | float | None
    hits: int
    false_positives: int
    precision: float | None
    target_held: bool
    stated: list[float] | None
    worlds: list[FreshWorld]

    @property
    def inside(self) -> tuple[int, int]:
        """(fresh worlds inside the stated interval, fresh worlds tested)."""
        tested = [w.inside for w in self.worlds if w.inside is not None]
        return sum(tested), len(tested)


@dataclass(frozen=True)
class VerdictCheck:
    """A paired verdict the board states ("a ahead" / "b ahead"), on the fresh worlds.

    Attributes:
        heading: the heading bin (or ``all``).
        a, b, stated, board_diff: the board's verdict and its difference of held-out recall (``a`` less ``b``).
        hits_a, hits_b, n_relevant: the fresh worlds' hits at the deployed thresholds and relevant pairs.
        fresh_diff: ``(hits_a - hits_b) / n_relevant`` (None: no relevant pair).
        held: whether the method the board states ahead is ahead on the fresh worlds too (None: no relevant pair).
        fresh_verdict, p_value: the same exact test on the fresh worlds (None: fewer than two fresh worlds).
        significant: whether the fresh worlds state the board's verdict too (None: not tested).
    """

    heading: str
    a: str
    b: str
    stated: str
    board_diff: float
    hits_a: int
    hits_b: int
    n_relevant: int
    fresh_diff: float | None
    held: bool | None
    fresh_verdict: str | None
    p_value: float | None
    significant: bool | None


@dataclass(frozen=True)
class LevelCheck:
    """One level's check: its fresh worlds, each method's precision and each stated verdict (``note``: why the
    level was not checked, None when it was)."""

    name: str
    worlds: list[str]
    precision: list[PrecisionCheck] = field(default_factory=list)
    verdicts: list[VerdictCheck] = field(default_factory=list)
    note: str | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class BoardCheck:
    """``check.json``: a board checked on fresh worlds (see the module docstring).

    Attributes:
        suite: the board's suite.
        seeds: the fresh seeds' range ``[A, B]`` (seeds A..B-1 at every level).
        target_precision, precision_slack: the board's target and the slack its flag allows.
        failed_cells: fresh cells that did not finish, with why.
        levels: one entry per level of the board.
    """

    suite: str
    seeds: list[int]
    target_precision: float
    precision_slack: float
    failed_cells: dict[str, str]
    levels: list[LevelCheck]

    def precision_held(self) -> tuple[int, int]:
        """(level x method rows whose pooled fresh precision met the target, rows)."""
        rows = [p for e in self.levels for p in e.precision]
        return sum(p.target_held for p in rows), len(rows)

    def worlds_inside(self) -> tuple[int, int]:
        """(fresh world x method x level inside the stated interval, tested)."""
        got = [p.inside for e in self.levels for p in e.precision]
        return sum(g[0] for g in got), sum(g[1] for g in got)

    def verdicts_held(self) -> tuple[int, int, int]:
        """(stated verdicts whose sign held on the fresh worlds, significant there too, stated verdicts)."""
        vs = [v for e in self.levels for v in e.verdicts]
        return sum(v.held is True for v in vs), sum(v.significant is True for v in vs), len(vs)


def read_check(path: str | Path) -> BoardCheck:
    """``check.json`` as a ``BoardCheck`` (``RecordError`` naming the file and field when malformed)."""
    return read_record(path, BoardCheck, CHECK_SCHEMA)
