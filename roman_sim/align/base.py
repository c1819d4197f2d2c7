"""The aligner interface: ``align(submap_a, submap_b) -> AlignResult``, and its registry.

``AlignResult.T_a_b`` maps points of submap b's frame into submap a's frame, so it
estimates ``inv(T_world_a) @ T_world_b``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.registry import Registry
from roman_sim.mapping.types import Submap


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
    """

    method: str
    T_a_b: NDArray[np.float64] | None
    associations: NDArray[np.int64]
    scores: NDArray[np.float64]
    runtime_s: float
    reason: str | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def n_associations(self) -> int:
        """Number of accepted associations (the loop-closure acceptance statistic)."""
        return int(len(self.associations))

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


@runtime_checkable
class Aligner(Protocol):
    """Anything with a ``name`` and ``align(a, b)``; a user's own method implements this."""

    name: str

    def align(self, a: Submap, b: Submap) -> AlignResult:
        """Align submap ``b`` to submap ``a``."""
        ...


#: Registry of aligner factories: ``ALIGNERS.get(name)(**params) -> Aligner``.
ALIGNERS: Registry[Any] = Registry("aligner")


def segment_associations(result: AlignResult) -> bool:
    """Whether ``result.associations`` index segments of the two submaps.

    Methods whose associations are something else (the visual method's feature matches,
    ``info["association_kind"] == "keyframe_features"``) are not graded against the true
    segment correspondences and draw no association lines.
    """
    return result.info.get("association_kind", "segments") == "segments"
