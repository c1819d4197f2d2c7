"""Association truth: which segment correspondences of a submap pair are true, and how many a
method's selected associations got right.

A segment's truth is its majority object id (``SubmapTruth.object_ids``; -1 for none). A
correspondence (i, j) is *true* when segment i of a and segment j of b have the same
majority object. Segments of one object may be split, so the correspondences *available*
to a one-to-one association are, per shared object, the smaller of its segment counts in
the two submaps; that is the denominator of association recall. Of a method's selected
associations, the *correct* ones are the true correspondences (the numerator of precision);
the *recovered* ones are the largest one-to-one subset of the correct ones (the numerator of
recall, so that a method listing one object twice is not credited twice). Every built-in
method selects one-to-one associations, where recovered = correct.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray
from scipy.sparse.csgraph import maximum_bipartite_matching

from roman_sim.core.errors import EvaluationError


def _ids(x: ArrayLike) -> NDArray[np.int64]:
    return np.asarray(x, dtype=np.int64).reshape(-1)


def true_correspondences(ids_a: ArrayLike, ids_b: ArrayLike) -> int:
    """Correspondences available one-to-one: sum over shared objects of min(count in a, count in b)."""
    a, b = _ids(ids_a), _ids(ids_b)
    ua, ca = np.unique(a[a >= 0], return_counts=True)
    ub, cb = np.unique(b[b >= 0], return_counts=True)
    _, ia, ib = np.intersect1d(ua, ub, assume_unique=True, return_indices=True)
    return int(np.minimum(ca[ia], cb[ib]).sum())


def shared_objects(ids_a: ArrayLike, ids_b: ArrayLike) -> int:
    """Distinct true objects with a segment in both submaps."""
    a, b = _ids(ids_a), _ids(ids_b)
    return int(len(np.intersect1d(a[a >= 0], b[b >= 0])))


def association_truth(ids_a: ArrayLike, ids_b: ArrayLike, associations: ArrayLike) -> tuple[int, int]:
    """(correct, recovered) of the selected associations ``(k, 2)`` (indices into a's and b's segments).

    Raises:
        EvaluationError: an index outside the submaps.
    """
    a, b = _ids(ids_a), _ids(ids_b)
    assoc = np.asarray(associations, dtype=np.int64).reshape(-1, 2)
    if len(assoc) == 0:
        return 0, 0
    if assoc.min() < 0 or assoc[:, 0].max() >= len(a) or assoc[:, 1].max() >= len(b):
        raise EvaluationError(f"associations index segments outside the submaps ({len(a)} and {len(b)} segments)")
    ok = (a[assoc[:, 0]] == b[assoc[:, 1]]) & (a[assoc[:, 0]] >= 0)
    correct = int(ok.sum())
    if correct == 0:
        return 0, 0
    # the distinct correct rows in (i, j) order: np.unique(rows, axis=0), through one integer per row
    code = np.unique(assoc[ok, 0] * len(b) + assoc[ok, 1])
    good = np.stack([code // len(b), code % len(b)], axis=1)
    if len(np.unique(good[:, 0])) == len(good) and len(np.unique(good[:, 1])) == len(good):
        return correct, int(len(good))  # already one-to-one
    graph = sp.csr_matrix((np.ones(len(good)), (good[:, 0], good[:, 1])), shape=(len(a), len(b)))
    recovered = int((maximum_bipartite_matching(graph, perm_type="column") >= 0).sum())
    return correct, recovered
