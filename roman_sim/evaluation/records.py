"""Small typed records of a run: map statistics and one method's estimate for one pair."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import AlignResult
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSONLike


@dataclass(frozen=True)
class MapStats:
    """Size of what the robots mapped and would share.

    Attributes:
        robots: robots with submaps.
        segments: finished segments of all robots (None when maps are not available).
        submaps: submaps of all robots.
        segments_per_submap: mean segments per submap.
        kb_per_submap, kb_per_submap_max: mean and largest submap packet (kB).
        trajectory_km: total true trajectory length (None without maps).
        mb_per_km: submap packets (MB) per km of trajectory.
        keyframes_per_submap: mean visual keyframes per submap (None without keyframes).
        keyframe_kb_per_submap, keyframe_kb_per_submap_max: mean and largest keyframe
            packet (kB), what the visual method shares, counted apart from the segments.
        keyframe_mb_per_km: keyframe packets (MB) per km of trajectory.
    """

    robots: int
    segments: int | None
    submaps: int
    segments_per_submap: float | None
    kb_per_submap: float | None
    kb_per_submap_max: float | None
    trajectory_km: float | None
    mb_per_km: float | None
    keyframes_per_submap: float | None = None
    keyframe_kb_per_submap: float | None = None
    keyframe_kb_per_submap_max: float | None = None
    keyframe_mb_per_km: float | None = None

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict (keyframe figures only when there are keyframes)."""
        d = asdict(self)
        return (
            d if self.keyframes_per_submap is not None else {k: v for k, v in d.items() if not k.startswith("keyframe")}
        )

    @classmethod
    def from_json(cls, d: Any, source: str = "map statistics") -> "MapStats":
        """Inverse of ``to_json`` (files without keyframe figures are read with None)."""
        try:
            values: dict[str, Any] = {
                f.name: d[f.name] if f.name in d or not f.name.startswith("keyframe") else None for f in fields(cls)
            }
            return cls(**values)
        except (KeyError, TypeError) as err:
            raise StorageError(f"{source}: malformed map statistics ({err})") from None


@dataclass(frozen=True)
class AlignmentRecord:
    """What one method estimated for one pair (the input of the pose graph's closures).

    Attributes:
        a, b: submap names (``robot/index``).
        method: method label.
        n_associations: accepted associations.
        T_a_b: 4x4 estimate of b's frame in a's (rounded to 1e-9), or None.
        associations: (k, 2) selected associations (indices into a's and b's segments).
    """

    a: str
    b: str
    method: str
    n_associations: int
    T_a_b: NDArray[np.float64] | None
    associations: NDArray[np.int64] = field(default_factory=lambda: np.zeros((0, 2), np.int64), compare=False)

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict."""
        return {
            "a": self.a,
            "b": self.b,
            "method": self.method,
            "n_associations": self.n_associations,
            "T_a_b": None if self.T_a_b is None else np.round(self.T_a_b, 9).tolist(),
            "associations": np.asarray(self.associations, dtype=np.int64).reshape(-1, 2).tolist(),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "AlignmentRecord":
        """Inverse of ``to_json``."""
        T = d["T_a_b"]
        return cls(
            str(d["a"]),
            str(d["b"]),
            str(d["method"]),
            int(d["n_associations"]),
            None if T is None else np.asarray(T, dtype=np.float64).reshape(4, 4),
            np.asarray(d.get("associations", []), dtype=np.int64).reshape(-1, 2),
        )

    def result(self) -> AlignResult:
        """An ``AlignResult`` holding this record's estimate and associations (for drawing)."""
        return AlignResult(
            self.method,
            self.T_a_b,
            np.asarray(self.associations, dtype=np.int64).reshape(-1, 2),
            np.ones(len(self.associations)),
            float("nan"),
            None if self.T_a_b is not None else "no estimate",
        )
