"""Shared helpers of the evaluation tests: hand-made submaps, pair truths, scores.

Exposed as factory fixtures (``make_submap``, ``make_truth``, ``make_score``, ``result_for``).
"""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align.base import AlignResult
from roman_sim.core.geometry import pose_4dof
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.mapping.types import Submap, SubmapTruth


def _make_submap(
    robot: str, index: int, x: float, y: float, yaw_deg: float = 0.0, object_ids=(0, 1, 2), with_points: bool = False
) -> Submap:
    """A submap whose segments are objects placed on a small grid around its centre."""
    ids = np.asarray(object_ids, dtype=np.int64)
    n = len(ids)
    centers = np.stack([np.arange(n) * 1.5 - n, (np.arange(n) % 3) * 2.0 - 2.0, np.full(n, 0.5)], 1)
    points = None
    if with_points:
        offs = np.array([[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0], [0, 0, 0.4]], dtype=float)
        points = [c + offs for c in centers]
    return Submap(
        robot=robot,
        index=index,
        t=float(index),
        T_odom_submap=pose_4dof(x, y, 0.0, np.radians(yaw_deg)),
        segment_ids=np.arange(n, dtype=np.int64) + 100 * index,
        centers=centers.astype(float),
        volumes=np.ones(n),
        shape=np.full((n, 3), 1 / 3),
        descriptors=np.eye(n, 8, dtype=np.float32),
        extents=np.tile([1.0, 0.5, 0.3], (n, 1)),
        points=points,
        truth=SubmapTruth(pose_4dof(x, y, 0.0, np.radians(yaw_deg)), ids, np.ones(n)),
    )


def _make_truth(
    name: str,
    relevant: bool,
    heading: float = 0.0,
    ambiguity: float = float("nan"),
    kind: str = "inter",
    true_corr: int = 0,
) -> PairTruth:
    """A pair truth with only the fields the metrics read set meaningfully."""
    return PairTruth(
        a=f"a/{name}",
        b=f"b/{name}",
        robot_a="a",
        robot_b="b" if kind == "inter" else "a",
        index_a=0,
        index_b=int(name) if name.isdigit() else 1,
        T_a_b_true=np.eye(4),
        center_dist_m=5.0 if relevant else 50.0,
        heading_diff_deg=heading,
        overlap=0.5,
        ambiguity=ambiguity,
        relevant=relevant,
        kind=kind,  # type: ignore[arg-type]
        shared_objects=true_corr,
        true_correspondences=true_corr,
    )


def _make_score(
    name: str,
    relevant: bool,
    n_assoc: int,
    correct: bool,
    method: str = "m",
    heading: float = 0.0,
    ambiguity: float = float("nan"),
    runtime: float = 0.1,
    kind: str = "inter",
    true_corr: int = 0,
    assoc_correct: int = 0,
) -> PairScore:
    """A scored pair with given counts and outcome (and association truth counts)."""
    err = 0.1 if correct else 40.0
    return PairScore(
        _make_truth(name, relevant, heading, ambiguity, kind, true_corr),
        method,
        n_assoc,
        err,
        err,
        correct,
        runtime,
        None if n_assoc else "no associations",
        assoc_correct,
        assoc_correct,
    )


def _result_for(T, n_assoc: int, method: str = "m", n_segments: int = 3) -> AlignResult:
    """An AlignResult with ``n_assoc`` associations (i % n_segments, i % n_segments)."""
    idx = np.arange(n_assoc) % n_segments
    assoc = np.stack([idx, idx], 1).astype(np.int64)
    return AlignResult(
        method=method,
        T_a_b=None if T is None else np.asarray(T, float),
        associations=assoc,
        scores=np.ones(n_assoc),
        runtime_s=0.01,
        reason=None if T is not None else "failed",
    )


@pytest.fixture(name="make_submap")
def _make_submap_fixture():
    return _make_submap


@pytest.fixture(name="make_truth")
def _make_truth_fixture():
    return _make_truth


@pytest.fixture(name="make_score")
def _make_score_fixture():
    return _make_score


@pytest.fixture(name="result_for")
def _result_for_fixture():
    return _result_for
