"""An external system's loop closures, replayed as an aligner's results.

The system ran outside the testbed; its closures were matched to this run's submap pairs
(``roman_sim.scoring.external``) and written to a table file. For a pair the table holds,
the result is the table's ``T_a_b`` with as many (placeholder) associations as the
closure's score, marked ``association_kind: external`` so they are not graded against the
true segment correspondences; any other pair is "no closure". The table's SHA-256 is a
parameter, so a changed table changes the evaluation's cache key, and a table that no
longer matches it is an error. A run names it by path: ``METHOD`` below.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from roman_sim.align.base import AlignResult
from roman_sim.core.errors import ConfigError
from roman_sim.core.records import RecordError, read_record
from roman_sim.mapping.types import Submap

TABLE_FORMAT = "roman_sim.closure_table"
NO_CLOSURE = "no closure from the external system"
#: The aligner's ``package.module:Class`` name in a scenario.
METHOD = "roman_sim.align.closure_table:ClosureTableAligner"


@dataclass(frozen=True)
class TableRow:
    """One submap pair's closure: the external estimate of ``T_a_b``, its score, its line in the closures file."""

    a: str
    b: str
    T_a_b: list[list[float]]
    n_assoc: int
    line: int


@dataclass(frozen=True)
class ClosureTable:
    """The table file: its format and version, the method's label, the closures file, one row per pair."""

    format: str
    version: int
    label: str
    closures: str
    pairs: list[TableRow]


def table_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a table file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


class ClosureTableAligner:
    """Looks each pair up in an external system's closure table (``table``: its path; ``sha256``: its hash)."""

    name = "closures"

    def __init__(self, table: str, sha256: str) -> None:
        path = Path(table)
        try:
            raw = path.read_bytes()
        except OSError as err:
            raise ConfigError(f"closures aligner: table {path}: cannot read it ({err.strerror or err})") from None
        if hashlib.sha256(raw).hexdigest() != sha256:
            raise ConfigError(f"closures aligner: table {path} changed since it was written (SHA-256 differs)")
        try:
            doc = read_record(path, ClosureTable)
        except RecordError as err:
            raise ConfigError(f"closures aligner: {err} (not a closure table)") from None
        if doc.format != TABLE_FORMAT:
            raise ConfigError(f"closures aligner: table {path}: format {doc.format!r}, not {TABLE_FORMAT!r}")
        try:
            self.pairs = {
                (p.a, p.b): (np.asarray(p.T_a_b, dtype=np.float64).reshape(4, 4), p.n_assoc) for p in doc.pairs
            }
        except ValueError as err:
            raise ConfigError(f"closures aligner: table {path}: a T_a_b is not 4 x 4 ({err})") from None

    def align(self, a: Submap, b: Submap) -> AlignResult:
        """The table's estimate of ``T_a_b`` (score as the association count), or "no closure"."""
        hit = self.pairs.get((a.name, b.name))
        if hit is None:
            return AlignResult.failure(self.name, NO_CLOSURE, association_kind="external")
        T, n = hit
        return AlignResult(
            self.name,
            T.copy(),
            np.full((n, 2), -1, dtype=np.int64),
            np.zeros(n),
            0.0,
            None,
            {"association_kind": "external"},
        )
