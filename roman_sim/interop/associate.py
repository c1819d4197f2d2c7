"""TUM RGB-D file lists and the association of time stamps between them.

A list (``rgb.txt``, ``depth.txt``, ``masks.txt``) has one ``timestamp filename`` per line;
lines starting with ``#`` are comments, commas and tabs count as spaces (as in the TUM
tools). ``associate`` pairs two stamp lists the way the benchmark's ``associate.py`` does:
candidate pairs closer than ``max_diff_s`` are taken greedily, closest first, each stamp
used at most once. Written here because ``associate.py`` is a script, not a library, and
compares every stamp with every other (quadratic); this version only considers each
stamp's two neighbours on the other list (sorted), which yields the same pairs whenever
the closest candidates are neighbours (always, for sorted lists), in O(n log n).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import StorageError


def read_list(path: str | Path) -> tuple[NDArray[np.float64], list[str]]:
    """Stamps (N,) and file names of a TUM list file, sorted by stamp."""
    p = Path(path)
    if not p.is_file():
        raise StorageError(f"{p}: file list not found")
    stamps, names = [], []
    for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), start=1):
        line = line.replace(",", " ").replace("\t", " ").strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        try:
            t = float(parts[0])
        except ValueError:
            raise StorageError(f"{p}:{n}: expected 'timestamp filename', got {line!r}") from None
        if len(parts) < 2 or not np.isfinite(t):
            raise StorageError(f"{p}:{n}: expected 'timestamp filename', got {line!r}")
        stamps.append(t)
        names.append(parts[1])
    order = np.argsort(np.asarray(stamps, dtype=np.float64), kind="stable")
    return np.asarray(stamps, dtype=np.float64)[order], [names[i] for i in order]


def associate(t_a: NDArray[np.float64], t_b: NDArray[np.float64],
              max_diff_s: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Index pairs ``(ia, ib)`` matching stamps ``t_a`` to ``t_b`` within ``max_diff_s``.

    Greedy, closest pair first, one-to-one; the result is ordered by ``ia``.
    """
    a0, b0 = np.asarray(t_a, dtype=np.float64), np.asarray(t_b, dtype=np.float64)
    if len(a0) == 0 or len(b0) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    oa, ob = np.argsort(a0, kind="stable"), np.argsort(b0, kind="stable")
    ia, ib = _associate_sorted(a0[oa], b0[ob], max_diff_s)
    ia, ib = oa[ia], ob[ib]
    order = np.argsort(ia, kind="stable")
    return ia[order], ib[order]


def _associate_sorted(a: NDArray[np.float64], b: NDArray[np.float64],
                      max_diff_s: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    cands = set()
    for src, dst, flip in ((a, b, False), (b, a, True)):
        pos = np.searchsorted(dst, src)
        for k in (pos - 1, pos):
            ok = (k >= 0) & (k < len(dst))
            for i, j in zip(np.flatnonzero(ok), k[ok]):
                cands.add((int(j), int(i)) if flip else (int(i), int(j)))
    pairs = sorted((abs(a[i] - b[j]), i, j) for i, j in cands if abs(a[i] - b[j]) < max_diff_s)
    used_a: set[int] = set()
    used_b: set[int] = set()
    out = []
    for _, i, j in pairs:
        if i not in used_a and j not in used_b:
            used_a.add(i)
            used_b.add(j)
            out.append((i, j))
    out.sort()
    ia = np.array([i for i, _ in out], dtype=np.int64)
    ib = np.array([j for _, j in out], dtype=np.int64)
    return ia, ib
