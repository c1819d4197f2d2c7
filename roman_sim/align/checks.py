"""Input checks shared by the aligners: a bad submap gives a reason string, never an exception.

Every aligner checks both submaps of every pair, so a submap is checked once per pair and
method. Inside ``remembered_checks`` (the alignment tasks run their pairs in it) the answer
for a submap object is kept and given again; the submaps must not change inside the block.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np

from roman_sim.align.registration import degeneracy
from roman_sim.mapping.types import Submap

#: Inside ``remembered_checks``: (id of the submap, label, shape, semantics) -> (the submap, its reason).
_REMEMBERED: ContextVar[dict[tuple[int, str, bool, bool], tuple[Submap, str | None]] | None] = ContextVar(
    "roman_sim_remembered_checks", default=None
)


@contextmanager
def remembered_checks() -> Iterator[None]:
    """Inside the block ``submap_reason`` checks each submap object once (the submaps must not change meanwhile)."""
    token = _REMEMBERED.set({})
    try:
        yield
    finally:
        _REMEMBERED.reset(token)


def _array_reason(name: str, x: object, shape_tail: tuple[int, ...], n: int) -> str | None:
    arr = np.asarray(x)
    if arr.ndim != 1 + len(shape_tail) or arr.shape[0] != n or tuple(arr.shape[1:]) != shape_tail:
        return f"{name} has shape {arr.shape}, expected ({n}, {', '.join(map(str, shape_tail))})".replace(", )", ")")
    if not np.issubdtype(arr.dtype, np.number) or not np.all(np.isfinite(arr)):
        return f"{name} has non-finite values"
    return None


def submap_reason(s: Submap, label: str, shape: bool = False, semantics: bool = False) -> str | None:
    """Why submap ``s`` cannot be aligned (None when fine)."""
    memo = _REMEMBERED.get()
    if memo is None:
        return _submap_reason(s, label, shape, semantics)
    key = (id(s), label, shape, semantics)
    if key not in memo:  # the entry holds the submap, so its id cannot be reused while the entry lives
        memo[key] = (s, _submap_reason(s, label, shape, semantics))
    return memo[key][1]


def _submap_reason(s: Submap, label: str, shape: bool, semantics: bool) -> str | None:
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
