"""A pool's workers share the cores: library thread counts set per worker, the user's own settings kept."""

from __future__ import annotations

import os

import pytest

from roman_sim.runner.executors import THREAD_VARS, thread_limits, threads_per_worker


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
