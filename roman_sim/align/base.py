"""The aligner interface: ``align(submap_a, submap_b) -> AlignResult``, and its registry.

``AlignResult.T_a_b`` maps points of submap b's frame into submap a's frame, so it
estimates ``inv(T_world_a) @ T_world_b``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import AlignmentError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import OMIT_EMPTY, OMIT_NONE
from roman_sim.core.registry import Registry
from roman_sim.mapping.types import Submap


@dataclass
class ResultRow:
    """An ``AlignResult`` as JSON values (floats exact, numpy extras made plain), with the names of
    the submaps ``a`` and ``b`` it aligned; the wall time is None (left out) where it is kept apart.
    """

    a: str
    b: str
    method: str
    T_a_b: list[list[float]] | None
    associations: list[list[int]]
    scores: list[float]
    reason: str | None
    info: dict[str, JSON]
    runtime_s: float | None = field(default=None, metadata=OMIT_NONE)
    confidence: dict[str, float] = field(default_factory=dict, metadata=OMIT_EMPTY)


#: The score every method offers: its number of accepted associations (the default confidence).
DEFAULT_SCORE = "associations"
#: What a score name may hold (it becomes a ``pairs.csv`` column ``score_<name>``).
SCORE_NAME = re.compile(r"^[a-z][a-z0-9_]{0,39}$")


@dataclass
class AlignResult:
    """Outcome of aligning two submaps.

    Attributes:
        method: aligner name.
        T_a_b: 4x4 estimate, or None when no transform could be computed.
        associations: (k, 2) int indices (into a's and b's segments) of the accepted associations.
        scores: (k,) per-association weights (solver's vector entries), or empty.
        runtime_s: wall time of the alignment.
        reason: why there is no alignment (None when ``T_a_b`` is set).
        info: method-specific extras (e.g. number of putative associations).
        confidence: the method's own named scores of this alignment, higher meaning more
            confident (e.g. ROMAN's ``objective``, ``margin``); the association count is always
            offered as ``associations`` and needs no entry. Names match ``SCORE_NAME``.
    """

    method: str
    T_a_b: NDArray[np.float64] | None
    associations: NDArray[np.int64]
    scores: NDArray[np.float64]
    runtime_s: float
    reason: str | None = None
    info: dict[str, Any] = field(default_factory=dict)
    confidence: dict[str, float] = field(default_factory=dict)

    @property
    def n_associations(self) -> int:
        """Number of accepted associations (the loop-closure acceptance statistic)."""
        return int(len(self.associations))

    @property
    def score(self) -> float:
        """The method's default confidence: the number of accepted associations."""
        return float(self.n_associations)

    def named_scores(self) -> dict[str, float]:
        """Every score of this result by name, ``associations`` first, the others sorted.

        Raises:
            AlignmentError: a name that is not ``SCORE_NAME`` or ``associations`` given again, or
                a value that is not a finite number (a method without a score for a pair leaves it out).
        """
        out = {DEFAULT_SCORE: self.score}
        for name in sorted(self.confidence):
            value = self.confidence[name]
            if name == DEFAULT_SCORE or not SCORE_NAME.match(str(name)):
                raise AlignmentError(
                    f"{self.method}: score name {name!r}: expected lower-case letters, digits and _ "
                    f"(at most 40, a letter first), other than {DEFAULT_SCORE!r}"
                )
            number = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
            if not number or not math.isfinite(float(value)):
                raise AlignmentError(f"{self.method}: score {name!r}: expected a finite number, got {value!r}")
            out[name] = float(value)
        return out

    @property
    def ok(self) -> bool:
        """Whether a transform was produced."""
        return self.T_a_b is not None

    @classmethod
    def failure(cls, method: str, reason: str, runtime_s: float = 0.0, **info: Any) -> "AlignResult":
        """A result that says "no alignment" and why."""
        return cls(
            method=method,
            T_a_b=None,
            associations=np.zeros((0, 2), dtype=np.int64),
            scores=np.zeros(0),
            runtime_s=runtime_s,
            reason=reason,
            info=dict(info),
        )

    def row(self, a: str, b: str) -> ResultRow:
        """The result on the pair ``a``, ``b`` as its JSON row (floats round-trip exactly through JSON)."""
        return ResultRow(
            a,
            b,
            self.method,
            None if self.T_a_b is None else np.asarray(self.T_a_b, dtype=np.float64).tolist(),
            np.asarray(self.associations, dtype=np.int64).reshape(-1, 2).tolist(),
            np.asarray(self.scores, dtype=np.float64).tolist(),
            self.reason,
            {str(k): _plain(x) for k, x in self.info.items()},
            float(self.runtime_s),
            {k: v for k, v in self.named_scores().items() if k != DEFAULT_SCORE},
        )

    @classmethod
    def from_row(cls, r: ResultRow) -> AlignResult:
        """Inverse of ``row`` (a row without its wall time reads with NaN)."""
        return cls(
            r.method,
            None if r.T_a_b is None else np.asarray(r.T_a_b, dtype=np.float64),
            np.asarray(r.associations, dtype=np.int64).reshape(-1, 2),
            np.asarray(r.scores, dtype=np.float64),
            math.nan if r.runtime_s is None else float(r.runtime_s),
            r.reason,
            dict(r.info),
            dict(r.confidence),
        )


def _plain(v: object) -> JSON:
    """``v`` with numpy values turned into JSON types (lists, floats, ints, bools; anything else its ``str``)."""
    if isinstance(v, np.ndarray):
        return _plain(v.tolist())
    if isinstance(v, np.generic):
        return _plain(v.item())
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    return str(v)


@runtime_checkable
class Aligner(Protocol):
    """Anything with a ``name`` and ``align(a, b)``; a user's own method implements this."""

    name: str

    def align(self, a: Submap, b: Submap) -> AlignResult:
        """Align submap ``b`` to submap ``a``."""
        ...


#: Registry of aligner factories: ``ALIGNERS.get(name)(**params) -> Aligner``.
ALIGNERS: Registry[Any] = Registry("aligner")


@dataclass(frozen=True)
class Tunable:
    """A constructor parameter of an aligner that ``roman-sim tune`` may vary.

    An aligner declares its tunable parameters as a class attribute
    ``tunable_params: dict[str, Tunable]`` (parameter name -> its bounds); ``tune`` refuses any
    other parameter of the method and any value outside ``[low, high]``.

    Attributes:
        low, high: the values allowed (inclusive).
        integer: whether the parameter takes integers only.
        default: the values tried when the user names the parameter without values (empty: not
            tried unless named).
        doc: one line saying what the parameter does.
    """

    low: float
    high: float
    integer: bool = False
    default: tuple[float, ...] = ()
    doc: str = ""


def declared_scores(factory: object) -> list[str] | None:
    """The named confidence scores an aligner class (or instance) declares it can give, as the class attribute
    ``confidence_scores`` (a tuple of names), after ``associations``, which every method offers; None when it
    declares none (a plug-in's scores are known only from its results). A declared score may still be missing
    from a result (ROMAN's ``semantic`` needs semantics on)."""
    raw = getattr(factory, "confidence_scores", None)
    if not isinstance(raw, tuple):
        return None
    return [DEFAULT_SCORE, *(str(x) for x in raw)]


def declared_tunables(factory: object) -> dict[str, Tunable]:
    """The ``tunable_params`` an aligner class (or instance) declares (empty when it declares none)."""
    raw = getattr(factory, "tunable_params", None)
    if not isinstance(raw, dict):
        return {}
    return {str(k): v for k, v in raw.items() if isinstance(v, Tunable)}


def segment_associations(result: AlignResult) -> bool:
    """Whether ``result.associations`` index segments of the two submaps.

    Methods whose associations are something else (the visual method's feature matches,
    ``info["association_kind"] == "keyframe_features"``) are not graded against the true
    segment correspondences and draw no association lines.
    """
    return result.info.get("association_kind", "segments") == "segments"
