"""One run over several workers: same bytes whatever the executor, task errors, resumption."""

from __future__ import annotations

import os
import shutil
import sys

import pytest

from roman_sim.core.errors import ConfigError, RomanSimError
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages import evaluation_job
from roman_sim.pipeline.stages import maps_robot as maps_stage
from roman_sim.runner.executors import ExecutorConfig, LocalPoolExecutor, SerialExecutor, TaskError, open_executor
from roman_sim.testing import assert_same_run_folder as assert_same_folder


def _fail_on_two(x: int) -> int:
    if x == 2:
        raise ConfigError("two is not allowed")
    return x * x


def _fail_from_two(x: int) -> int:
    if x <= 2:
        raise ConfigError("two is not allowed" if x == 2 else "one is not allowed")
    if x == 5:
        raise ConfigError("five is not allowed")
    return x


def _divide(x: int) -> float:
    return 1 / x


def _pid(_: int) -> int:
    return os.getpid()


def test_serial_and_pool_give_results_in_task_order_and_name_the_failing_worker():
    args = [(i,) for i in range(5)]
    with SerialExecutor() as ex:
        assert ex.map(abs, [(-i,) for i in range(5)], ["t"] * 5) == [0, 1, 2, 3, 4]
        with pytest.raises(ConfigError, match="two is not allowed"):  # in-process: the task's own error
            ex.map(_fail_on_two, args, [f"task {i}" for i in range(5)])
    with LocalPoolExecutor(2) as ex:
        assert ex.map(_fail_on_two, [(i,) for i in (0, 1, 3)], ["a", "b", "c"]) == [0, 1, 9]
        assert os.getpid() not in ex.map(_pid, args, ["p"] * 5)
        with pytest.raises(ConfigError, match="^two is not allowed$"):  # the package's errors unchanged
            ex.map(_fail_on_two, args, [f"task {i}" for i in range(5)])
        with pytest.raises(ConfigError, match="^five is not allowed$"):  # the lowest failed index wins
            ex.map(_fail_from_two, [(i,) for i in (5, 4, 3, 2, 1)], [f"task {i}" for i in range(5)])
        with pytest.raises(TaskError, match=r"^task 1 failed: ZeroDivisionError: division by zero \(at "):
            ex.map(_divide, [(1,), (0,), (2,)], ["task 0", "task 1", "task 2"])


def test_open_executor_kinds():
    assert isinstance(open_executor(None), SerialExecutor)
    assert isinstance(open_executor(ExecutorConfig(kind="local", workers=1)), SerialExecutor)
    pool = open_executor(ExecutorConfig(kind="local", workers=3))
    assert isinstance(pool, LocalPoolExecutor) and pool.workers == 3
    assert ExecutorConfig(kind="local").n_workers() == (os.cpu_count() or 1)


@pytest.mark.slow
def test_smoke_on_local_pool_and_loopback_dask_cluster_gives_the_serial_bytes(smoke_run, tmp_path):
    """The same folder from 2 pool workers (small chunks) and a 2-worker Dask LocalCluster."""
    sc = load_scenario("smoke")
    pool = Experiment(sc, tmp_path / "pool", executor=ExecutorConfig(kind="local", workers=2, chunk_pairs=7)).run()
    assert pool.timings.stages["evaluation"].pairs.executor == "local"
    assert_same_folder(smoke_run.run_dir, pool.run_dir)
    dask = Experiment(sc, tmp_path / "dask", executor=ExecutorConfig(kind="dask", workers=2, chunk_pairs=50)).run()
    pairs = dask.timings.stages["evaluation"].pairs
    assert pairs is not None and (pairs.executor, pairs.workers) == ("dask", 2)
    assert_same_folder(smoke_run.run_dir, dask.run_dir)


class Interrupt(BaseException):
    """Stands for Ctrl-C / a killed job (not an Exception, like KeyboardInterrupt)."""


def test_interrupted_run_resumes_per_robot_and_per_chunk_to_the_same_bytes(smoke_run, tmp_path, monkeypatch):
    sc = load_scenario("smoke")
    run_dir = tmp_path / "run"
    ex = ExecutorConfig(kind="serial", chunk_pairs=8)
    real_map, real_chunk = maps_stage.map_source, evaluation_job.align_chunk_task
    mapped: list[str] = []
    chunks: list[int] = []

    def map_source(ctx, source, *args, **kwargs):
        if source.name == "b" and "interrupted" not in mapped:
            mapped.append("interrupted")
            raise Interrupt
        mapped.append(source.name)
        return real_map(ctx, source, *args, **kwargs)

    def align_chunk(spec, submaps, pairs):
        chunks.append(len(pairs))
        if len(chunks) == 3:
            raise Interrupt
        return real_chunk(spec, submaps, pairs)

    monkeypatch.setattr(maps_stage, "map_source", map_source)
    monkeypatch.setattr(evaluation_job, "align_chunk_task", align_chunk)
    with pytest.raises(Interrupt):  # robot a finished, b interrupted
        Experiment(sc, run_dir, executor=ex).run()
    assert mapped == ["a", "interrupted"]
    assert (run_dir / "partial" / "maps" / "a.json").is_file() and not (run_dir / "maps" / "b.npz").exists()
    with pytest.raises(Interrupt):  # b mapped (a reused), evaluation interrupted in its third chunk
        Experiment(sc, run_dir, executor=ex).run()
    assert mapped == ["a", "interrupted", "b"]
    assert len(list((run_dir / "partial" / "evaluation").glob("*.json"))) == 2
    assert not (run_dir / "partial" / "maps").exists()  # the maps stage completed
    Experiment(sc, run_dir, executor=ex).run()
    n_pairs = smoke_run.metrics.n_pairs
    n_chunks = -(-n_pairs // 8)
    assert len(chunks) == 3 + (n_chunks - 2)  # the two finished chunks were not aligned again
    assert sum(chunks[3:]) == n_pairs - 16
    assert not (run_dir / "partial").exists()
    assert_same_folder(smoke_run.run_dir, run_dir)


def test_checkpoints_of_another_configuration_are_ignored(smoke_run, tmp_path, monkeypatch):
    """A checkpoint under another stage key (other aligner settings) is recomputed, not reused."""
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    fake = run_dir / "partial" / "evaluation"
    fake.mkdir(parents=True)
    calls: list[int] = []
    real_chunk = evaluation_job.align_chunk_task

    def align_chunk(spec, submaps, pairs):
        calls.append(len(pairs))
        return real_chunk(spec, submaps, pairs)

    monkeypatch.setattr(evaluation_job, "align_chunk_task", align_chunk)
    first = sorted(smoke_run.metrics.methods)
    (fake / "stale.json").write_text('{"schema": "roman_sim.checkpoint/1", "key": "other", "data": []}')
    Experiment(load_scenario("smoke"), run_dir, from_stage="evaluation").run()
    assert sum(calls) == smoke_run.metrics.n_pairs
    assert sorted(smoke_run.metrics.methods) == first
    assert_same_folder(smoke_run.run_dir, run_dir)


def test_a_task_error_stops_the_run_with_one_line(tmp_path):
    sc = load_scenario(
        "smoke",
        [
            "robots.0.max_length_m=6",
            "robots.1.max_length_m=6",
            "aligners=[roman, 'no_such_module_xyz:Aligner']",
            "posegraph_method=roman",
        ],
    )
    with pytest.raises(RomanSimError, match="no_such_module_xyz"):
        Experiment(sc, tmp_path / "r", executor=ExecutorConfig(kind="local", workers=2)).run()


# -- workers die with their run, and a stop is bounded -------------------------------------------


def _worker_state(_: int) -> tuple[int, object, int]:
    """(pid, SIGINT disposition, parent-death signal) as a pool worker sees them."""
    import ctypes
    import signal

    sig = ctypes.c_int(0)
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(2, ctypes.byref(sig), 0, 0, 0)  # PR_GET_PDEATHSIG
    return os.getpid(), signal.getsignal(signal.SIGINT), sig.value


def _stubborn(marker: str) -> None:
    """Ignore SIGTERM, say so in ``marker`` (with this pid), then never return."""
    import signal
    import time

    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    with open(marker, "w") as fh:
        fh.write(str(os.getpid()))
    time.sleep(3600)


def _never_starts(lifeline: object, marker: str) -> None:
    """A worker initialiser that ignores SIGTERM, says so in ``marker`` and never returns: a worker never started."""
    import signal
    import time

    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    with open(marker, "w") as fh:
        fh.write(str(os.getpid()))
    time.sleep(3600)


def _gone(pid: int) -> bool:
    import psutil

    try:
        return psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True


def _wait(cond, timeout_s: float = 10.0) -> bool:
    import time

    deadline = time.monotonic() + timeout_s
    while not cond() and time.monotonic() < deadline:
        time.sleep(0.05)
    return cond()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_pool_workers_ignore_sigint_die_with_their_parent_and_when_the_lifeline_is_cut():
    import signal

    ex = LocalPoolExecutor(2)
    states = ex.map(_worker_state, [(i,) for i in range(4)], ["state"] * 4)
    assert {(s[1], s[2]) for s in states} == {(signal.SIG_IGN, signal.SIGKILL)}
    pids = {s[0] for s in states}
    assert ex._lifeline is not None
    ex._lifeline.cut()  # what the kernel does when this process dies: every worker kills itself
    assert _wait(lambda: all(_gone(p) for p in pids)), pids
    ex.close()  # the pool sees its workers gone and stops at once


def test_close_ends_a_worker_that_never_answers_within_its_bound(tmp_path):
    import time

    ex = LocalPoolExecutor(1)
    ex.stop_grace_s, ex.kill_after_s = 0.5, 0.5
    marker = tmp_path / "pid"
    fut = ex._get_pool().submit(_stubborn, str(marker))
    assert _wait(lambda: marker.is_file() and marker.read_text() != "", 120.0)  # the worker imports this module
    pid = int(marker.read_text())
    t0 = time.monotonic()
    ex.close()
    took = time.monotonic() - t0
    assert 0.5 + 0.5 <= took < 0.5 + 2 * 0.5 + 3.0  # grace, SIGTERM (ignored), SIGKILL, with slack for a busy CPU
    assert _wait(lambda: _gone(pid), 5.0)
    assert fut.done()


def test_close_ends_a_worker_that_never_started_within_its_bound(monkeypatch, tmp_path):
    import functools
    import time

    from roman_sim.runner import executors

    marker = tmp_path / "pid"
    monkeypatch.setattr(executors, "worker_init", functools.partial(_never_starts, marker=str(marker)))
    ex = LocalPoolExecutor(1)
    ex.stop_grace_s, ex.kill_after_s = 0.5, 0.5
    fut = ex._get_pool().submit(abs, -1)
    assert _wait(lambda: marker.is_file() and marker.read_text() != "", 120.0)  # stuck in its initialiser
    pid = int(marker.read_text())
    t0 = time.monotonic()
    ex.close()
    took = time.monotonic() - t0
    assert 0.5 + 0.5 <= took < 0.5 + 2 * 0.5 + 3.0  # grace, SIGTERM (ignored) and its wait, then SIGKILL
    assert _wait(lambda: _gone(pid), 5.0)
    assert not fut.done() or fut.exception() is not None


def test_signals_are_held_back_inside_signals_deferred_and_delivered_after():
    import signal
    import threading
    import time

    from roman_sim.runner.lifeline import signals_deferred

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals reach the main thread only")
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("SIGINT is not the default handler here")
    reached = []
    with pytest.raises(KeyboardInterrupt):
        with signals_deferred():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.1)  # the handler would run here
            reached.append(True)
    assert reached == [True]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
