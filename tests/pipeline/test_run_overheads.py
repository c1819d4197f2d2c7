"""What cuts a run's fixed costs keeps its values: thread limits, the pickled world, remembered checks, Wilson."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

from roman_sim.align import checks
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.evaluation.assoc import association_truth
from roman_sim.evaluation.intervals import wilson
from roman_sim.mapping.types import Submap
from roman_sim.runner.executors import THREAD_VARS, thread_limits, threads_per_worker
from roman_sim.world import PickledWorld, generate, load_world_spec


def test_thread_limits_set_only_the_unset_variables_and_restore_them(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(THREAD_VARS[0], "3")
    for v in THREAD_VARS[1:]:
        monkeypatch.delenv(v, raising=False)
    with thread_limits(workers=10**6):
        assert os.environ[THREAD_VARS[0]] == "3"  # the user's setting is kept
        assert all(os.environ[v] == "1" for v in THREAD_VARS[1:])
    assert os.environ[THREAD_VARS[0]] == "3"
    assert not any(v in os.environ for v in THREAD_VARS[1:])


def test_threads_per_worker_share_the_cores() -> None:
    assert threads_per_worker(1) >= threads_per_worker(2) >= threads_per_worker(10**6) == 1


def test_a_pickled_world_loads_as_the_generated_one() -> None:
    world = generate(load_world_spec("tiny"), 0)
    back = PickledWorld.of(world).load()
    assert world.mjspec is not None and back.mjspec is None  # the spec stays home; the original keeps it
    assert pickle.dumps(back.model) == pickle.dumps(world.model)
    assert pickle.dumps(back.truth) == pickle.dumps(world.truth)
    assert back.meshes.keys() == world.meshes.keys()
    assert (back.spec, back.seed) == (world.spec, world.seed)


def test_remembered_checks_give_the_same_reasons_checking_each_submap_once(monkeypatch: pytest.MonkeyPatch) -> None:
    a, b, _ = make_submap_pair(3, 10, 5, 5)
    bad = a.public()
    bad.centers = np.zeros_like(a.centers)  # coincident centres
    calls: list[int] = []
    inner = checks._submap_reason

    def counted(s: Submap, label: str, shape: bool, semantics: bool) -> str | None:
        calls.append(id(s))
        return inner(s, label, shape, semantics)

    plain = [checks.pair_reason(x, y, True, True) for x, y in ((a, b), (bad, b), (a, b))]
    monkeypatch.setattr(checks, "_submap_reason", counted)
    with checks.remembered_checks():
        kept = [checks.pair_reason(x, y, True, True) for x, y in ((a, b), (bad, b), (a, b))]
    assert kept == plain and plain[0] is None and "coincident" in str(plain[1])
    assert sorted(calls) == sorted([id(a), id(b), id(bad)])
    calls.clear()
    checks.pair_reason(a, b)  # outside the block nothing is remembered
    assert calls == [id(a), id(b)]


def test_wilson_intervals_are_the_same_asked_again() -> None:
    first = [wilson(k, n) for n in (1, 5, 44) for k in range(n + 1)]
    assert [wilson(k, n) for n in (1, 5, 44) for k in range(n + 1)] == first
    assert wilson(0, 0) is None


def test_association_truth_counts_distinct_correct_rows() -> None:
    ids_a, ids_b = [0, 1, 1, -1], [1, 0, 0, -1]
    # (0, 1) and (0, 2) both correct for object 0, (1, 0) twice, (3, 3) has no object
    assoc = [[0, 1], [0, 2], [1, 0], [1, 0], [3, 3], [2, 2]]
    assert association_truth(ids_a, ids_b, assoc) == (4, 2)
    assert association_truth(ids_a, ids_b, [[3, 3]]) == (0, 0)
