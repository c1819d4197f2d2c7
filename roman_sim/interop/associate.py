"""TUM RGB-D file lists and the association of time stamps between them.

A list (``rgb.txt``, ``depth.txt``, ``masks.txt``) has one ``timestamp filename`` per line;
lines starting with ``#`` are comments, commas and tabs count as spaces (as in the TUM
tools). ``associate`` pairs two stamp lists the way the benchmark's ``associate.py`` does:
every pair closer than ``max_diff_s`` is a candidate, candidates are taken greedily,
closest first, each stamp used at most once. Written here because ``associate.py`` is a
script, not a library, and compares every stamp with every other (quadratic); this
version finds the candidates of each stamp by binary search in the sorted other list
(the same pairs, in O(n log n + candidates)). ``roman_sim.evaluation.ate.associate``
differs on purpose: it keeps, per reference stamp, the earliest estimate, not the closest.
"""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import StorageError
from roman_sim.core.tum import MAX_TIME_S, field_problem


def read_list(path: str | Path, epoch_ns: int = 0) -> tuple[NDArray[np.float64], list[str]]:
    """Stamps (N,) and file names of a TUM list file, sorted by stamp.

    With ``epoch_ns`` the stamps are seconds after that epoch, taken off the decimal text
    exactly (so a nine-decimal stamp comes back to the nanosecond).
    """
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
            t = float(parts[0]) if not epoch_ns else float(Decimal(parts[0]) - Decimal(epoch_ns) / 10**9)
        except (ValueError, ArithmeticError):
            raise StorageError(f"{p}:{n}: expected 'timestamp filename', got {line!r}") from None
        if len(parts) < 2:
            raise StorageError(f"{p}:{n}: expected 'timestamp filename', got {line!r}")
        bad = field_problem("timestamp", t, MAX_TIME_S, "s")
        if bad is not None:
            raise StorageError(f"{p}:{n}: {bad}")
        stamps.append(t)
        names.append(parts[1])
    order = np.argsort(np.asarray(stamps, dtype=np.float64), kind="stable")
    return np.asarray(stamps, dtype=np.float64)[order], [names[i] for i in order]


def associate(
    t_a: NDArray[np.float64], t_b: NDArray[np.float64], max_diff_s: float
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
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


def _associate_sorted(
    a: NDArray[np.float64], b: NDArray[np.float64], max_diff_s: float
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    lo = np.searchsorted(b, a - max_diff_s, side="left")
    hi = np.searchsorted(b, a + max_diff_s, side="right")
    counts = hi - lo
    ia = np.repeat(np.arange(len(a)), counts)
    ib = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts - lo, counts)
    diff = np.abs(a[ia] - b[ib])
    ok = diff < max_diff_s
    ia, ib, diff = ia[ok], ib[ok], diff[ok]
    order = np.lexsort((ib, ia, diff))  # closest first; ties by index, as sorting the tuples would
    used_a = np.zeros(len(a), dtype=bool)
    used_b = np.zeros(len(b), dtype=bool)
    out_a, out_b = [], []
    for i, j in zip(ia[order].tolist(), ib[order].tolist()):
        if not used_a[i] and not used_b[j]:
            used_a[i] = used_b[j] = True
            out_a.append(i)
            out_b.append(j)
    return np.asarray(out_a, dtype=np.int64), np.asarray(out_b, dtype=np.int64)
