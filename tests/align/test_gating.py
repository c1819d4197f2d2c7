"""Submap gating: descriptors, which pairs are kept, and its effect on a run (gated pairs are misses)."""

from __future__ import annotations

import csv
import shutil

import numpy as np
import pytest

from roman_sim.align.gating import GATED_REASON, GatingConfig, gate_pairs, submap_descriptor
from roman_sim.evaluation.pairs import enumerate_pairs
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages.submaps import SubmapsStage


def _submap(robot: str, index: int, desc: list[list[float]], volumes: list[float]) -> Submap:
    n = len(desc)
    d = np.asarray(desc, dtype=np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return Submap(
        robot=robot,
        index=index,
        t=float(index),
        T_odom_submap=np.eye(4),
        segment_ids=np.arange(n, dtype=np.int64),
        centers=np.zeros((n, 3)),
        volumes=np.asarray(volumes, dtype=np.float64),
        shape=np.tile([0.2, 0.3, 0.5], (n, 1)),
        descriptors=d,
        extents=np.ones((n, 3)),
    )


def test_descriptor_is_unit_and_similar_submaps_score_higher():
    cfg = GatingConfig(enabled=True)
    a = _submap("a", 0, [[1, 0, 0], [0, 1, 0]], [0.5, 2.0])
    same = _submap("b", 0, [[0, 1, 0], [1, 0, 0]], [2.0, 0.5])  # the same segments, other order
    other = _submap("b", 1, [[0, 0, 1], [0, 0, 1]], [50.0, 60.0])
    da, ds, do = (submap_descriptor(s, cfg) for s in (a, same, other))
    assert np.linalg.norm(da) == pytest.approx(1.0, abs=1e-12)
    assert float(da @ ds) == pytest.approx(1.0, abs=1e-12)
    assert float(da @ do) < 0.5
    # by hand: semantic blocks orthogonal, size histograms disjoint, shape identical (weight 0.5)
    assert float(da @ do) == pytest.approx(0.25 / 2.25, abs=1e-12)
    empty = _submap("c", 0, [[1, 0, 0]], [1.0])
    empty.segment_ids = np.zeros(0, dtype=np.int64)
    assert not np.any(submap_descriptor(empty, cfg))


def test_top_k_and_threshold_keep_the_most_similar_candidates():
    q = _submap("a", 0, [[1, 0, 0], [0, 1, 0]], [0.5, 2.0])
    near = _submap("b", 0, [[1, 0, 0], [0, 1, 0]], [0.5, 2.0])
    mid = _submap("b", 1, [[1, 0, 0], [0, 0, 1]], [0.5, 2.0])
    far = _submap("b", 2, [[0, 0, 1], [0, 0, 1]], [50.0, 60.0])
    pairs = [(q, far), (q, mid), (q, near)]
    keep, sims = gate_pairs(pairs, GatingConfig(enabled=True, top_k=1))
    assert sims[2] > sims[1] > sims[0]
    # q's best is near; each b submap has only one candidate, so its own top-1 keeps it too
    assert keep == [True, True, True]
    more = pairs + [(mid, near), (far, near)]
    keep, sims = gate_pairs(more, GatingConfig(enabled=True, top_k=1))
    best = {}  # each submap's most similar candidate (first one on ties)
    for i, (a, b) in enumerate(more):
        for s in (a.name, b.name):
            if s not in best or sims[i] > sims[best[s]]:
                best[s] = i
    assert keep == [i in best.values() for i in range(len(more))]
    assert not all(keep) and keep[2]  # (q, near) is everybody's best
    keep, _ = gate_pairs(pairs, GatingConfig(enabled=True, top_k=None, min_similarity=sims[1]))
    assert keep == [False, True, True]
    assert gate_pairs(pairs, GatingConfig(enabled=False))[0] == [True, True, True]
    empty = _submap("c", 0, [[1, 0, 0]], [1.0])
    empty.segment_ids, empty.descriptors = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float32)
    keep, sims = gate_pairs([(q, empty), (q, near)], GatingConfig(enabled=True, top_k=1))
    assert keep == [True, True] and sims[0] == 0.0  # an empty submap: zero similarity, still its own best


def test_gated_run_aligns_only_kept_pairs_and_counts_the_rest_as_misses(smoke_run, tmp_path):
    run_dir = tmp_path / "gated"
    shutil.copytree(smoke_run.run_dir, run_dir)
    sc = load_scenario("smoke", ["gating.enabled=true", "gating.top_k=2"])
    res = Experiment(sc, run_dir, from_stage="evaluation").run()
    subs = SubmapsStage().load(Experiment(sc, run_dir).context(), []).all()
    ec = sc.evaluation
    pairs = enumerate_pairs(subs, ec.intra_min_gap, ec.max_pair_dist_m, ec.relevant_dist_m)
    keep, _ = gate_pairs(pairs, sc.gating)
    assert 0 < sum(keep) < len(pairs)
    figures = res.timings.stages["evaluation"].pairs
    assert figures is not None and (figures.candidates, figures.aligned) == (len(pairs), sum(keep))
    rows = list(csv.DictReader((run_dir / "pairs.csv").open()))
    gated = {(r["a"], r["b"]) for r in rows if r["reason"] == GATED_REASON}
    assert gated == {(a.name, b.name) for (a, b), k in zip(pairs, keep) if not k}
    assert all(r["n_assoc"] == "0" and r["correct"] == "false" for r in rows if r["reason"] == GATED_REASON)
    assert res.metrics.n_pairs == smoke_run.metrics.n_pairs
    for m in ("roman", "clipper"):  # gating only removes candidates
        assert res.recall(m) <= smoke_run.recall(m)
