"""Input checks shared by the aligners: a bad submap gives a reason string, never an exception."""

from __future__ import annotations

import numpy as np

from roman_sim.align.registration import degeneracy
from roman_sim.mapping.types import Submap


def _array_reason(name: str, x: object, shape_tail: tuple[int, ...], n: int) -> str | None:
    arr = np.asarray(x)
    if arr.ndim != 1 + len(shape_tail) or arr.shape[0] != n or tuple(arr.shape[1:]) != shape_tail:
        return f"{name} has shape {arr.shape}, expected ({n}, {', '.join(map(str, shape_tail))})".replace(", )", ")")
    if not np.issubdtype(arr.dtype, np.number) or not np.all(np.isfinite(arr)):
        return f"{name} has non-finite values"
    return None


def submap_reason(s: Submap, label: str, shape: bool = False, semantics: bool = False) -> str | None:
    """Why submap ``s`` cannot be aligned (None when fine)."""
    c = np.asarray(s.centers)
    n = len(c)
    if n < 3:
        return f"submap {label} has fewer than 3 segments ({n})"
    why = _array_reason(f"submap {label} centers", c, (3,), n)
    if why is None:
        why = degeneracy(c, 6)
        why = f"submap {label}: {why}" if why else None
    if why is None and shape:
        why = _array_reason(f"submap {label} volumes", s.volumes, (), n) or _array_reason(
            f"submap {label} shape", s.shape, (3,), n
        )
    if why is None and semantics:
        d = np.asarray(s.descriptors)
        if d.ndim != 2 or len(d) != n or d.shape[1] == 0:
            return f"submap {label} descriptors have shape {d.shape}, expected ({n}, D)"
        why = _array_reason(f"submap {label} descriptors", d, (d.shape[1],), n)
        if why is None and np.any(np.linalg.norm(d.astype(np.float64), axis=1) <= 1e-12):
            why = f"submap {label} has zero descriptors"
    return why


def pair_reason(a: Submap, b: Submap, shape: bool = False, semantics: bool = False) -> str | None:
    """Why the pair cannot be aligned (None when fine)."""
    why = submap_reason(a, "a", shape, semantics) or submap_reason(b, "b", shape, semantics)
    if why is None and semantics:
        da, db = np.asarray(a.descriptors).shape[1], np.asarray(b.descriptors).shape[1]
        if da != db:
            why = f"descriptor sizes differ ({da} vs {db})"
    return why
