"""Where a run's independent tasks execute: in this process, a local process pool or a Dask cluster.

One interface serves a run (one task per robot to render and map, one per chunk of submap
pairs to align) and a sweep (one task per cell). ``Executor.run_tasks`` yields
``(index, result)`` as tasks finish, so the caller can checkpoint each one; callers put the
results in task order, so the output never depends on the executor, the worker count or the
order in which tasks finish. Task functions are top-level functions of importable modules
(the pool and Dask pickle them by reference) and return plain data.

When tasks fail, the pending tasks are cancelled (on the local pool the running ones still
finish and are yielded, so the caller checkpoints them), and the error of the failed task
with the lowest index is raised once nothing runs any more. The package's
own errors (``RomanSimError``) reach the caller unchanged from the local pool and, on Dask,
as a ``TaskError`` that also names the worker's address; any other exception (a bug, a
plug-in's own error) becomes a ``TaskError`` naming the task.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from multiprocessing import forkserver
from multiprocessing.connection import Connection
from typing import TypeVar

from roman_sim.runner.executor_base import (
    Executor,
    ExecutorConfig,
    TaskError,
    collect,
    guarded,
    worker_name,
)
from roman_sim.runner.lifeline import (
    Lifeline,
    end_processes,
    parent_sys_path,
    sigint_ignored,
    signals_deferred,
    worker_init,
)
from roman_sim.runner.preload import PRELOAD_ENV

log = logging.getLogger(__name__)

T = TypeVar("T")


class SerialExecutor(Executor):
    """Every task in this process, one after the other (errors unchanged)."""

    def run_tasks(
        self, fn: Callable[..., T], args: Sequence[tuple[object, ...]], labels: Sequence[str]
    ) -> Iterator[tuple[int, T]]:
        for i, a in enumerate(args):
            yield i, fn(*a)


#: Environment variables that size the thread pools of libraries tasks use: OpenCV and Mesa's
#: software renderer (llvmpipe), whose results do not depend on their thread counts. BLAS and
#: OpenMP are left alone: OpenBLAS sums dot products and matrix products in other orders with
#: another thread count (other bits), and a run's bytes must not depend on where a task ran.
THREAD_VARS = ("OPENCV_FOR_THREADS_NUM", "LP_NUM_THREADS")
#: The forkserver's preload module: it loads the pool's preload entries (``roman_sim.runner.preload``).
PRELOAD_MODULE = "roman_sim.runner.preload"


def threads_per_worker(workers: int) -> int:
    """Threads each library may start in one of ``workers`` workers: this machine's cores shared out, at least 1."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, cores // max(1, workers))


@contextmanager
def thread_limits(workers: int) -> Iterator[None]:
    """``THREAD_VARS`` set to ``threads_per_worker(workers)`` inside the block (those the user set are kept).

    Processes started inside the block (the forkserver, hence every worker) size those
    libraries' thread pools by it, so ``workers`` workers do not each start a thread per
    core and fight over the cores; these thread counts change no result.
    """
    n = str(threads_per_worker(workers))
    added = [v for v in THREAD_VARS if v not in os.environ]
    os.environ.update({v: n for v in added})
    try:
        yield
    finally:
        for v in added:
            os.environ.pop(v, None)


@contextmanager
def _preload_entries(preload: Sequence[str]) -> Iterator[None]:
    """``PRELOAD_ENV`` set to ``preload`` inside the block (for the forkserver started there)."""
    old = os.environ.get(PRELOAD_ENV)
    os.environ[PRELOAD_ENV] = ",".join(preload)
    try:
        yield
    finally:
        if old is None:
            os.environ.pop(PRELOAD_ENV, None)
        else:
            os.environ[PRELOAD_ENV] = old


def start_forkserver(workers: int, preload: Sequence[str] = ()) -> None:
    """Launch multiprocessing's forkserver (once per process) with ``preload`` and ``workers``' thread limits.

    ``preload``: the entries ``roman_sim.runner.preload`` loads before a worker forks
    (modules, warm-ups, or a ``module:name`` that lists more). Returns at once: the
    forkserver loads them in the background, and the first worker forks when it is done.
    Its settings are those of the first call: a forkserver already running is kept as it is.
    """
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload([PRELOAD_MODULE] if preload else [])
    # Ctrl-C ignored while it imports; this process's modules; the workers' thread counts; what to preload
    with sigint_ignored(), parent_sys_path(), thread_limits(workers), _preload_entries(preload):
        forkserver.ensure_running()


def prestart(cfg: ExecutorConfig | None, preload: Sequence[str]) -> None:
    """Launch the forkserver of the local pool ``cfg`` describes, with ``preload``, if it describes one.

    For the command line: called before it imports the code of the tasks, so the forkserver
    imports it while the command imports its own and generates the world (``preload`` may
    be one ``module:name`` entry that lists the rest). A command that stops early leaves
    nothing behind: the preload ends when this process does (``roman_sim.runner.preload``).
    """
    if cfg is not None and cfg.kind == "local" and cfg.n_workers() > 1:
        start_forkserver(cfg.n_workers(), preload)


class LocalPoolExecutor(Executor):
    """A pool of worker processes on this machine (``forkserver``: no threads or GL state are forked).

    Workers are forked from multiprocessing's forkserver, which loads ``preload`` once
    (``start_forkserver``; a run's pool: every module its stages' tasks use, so no worker
    imports them again); ``start`` launches it ahead of the first task so that it imports
    while the caller works on. Workers size their libraries' thread pools to their share of the
    cores (``thread_limits``) and take this process's ``sys.path`` when the pool is made.

    Workers die with the main process however it ends (``roman_sim.runner.lifeline``). An
    interrupt (or the caller abandoning ``run_tasks``) cancels the pending tasks and ends the
    running ones at once; ``close`` ends workers still alive ``stop_grace_s`` after the pool
    was asked to stop (a worker that never started or never answers), so stopping is bounded.
    """

    kind = "local"
    #: Bound on an orderly stop (s): workers still alive then are sent SIGTERM.
    stop_grace_s = 5.0
    #: Bound after SIGTERM (s): workers still alive then are sent SIGKILL.
    kill_after_s = 2.0

    def __init__(self, workers: int, preload: Sequence[str] = ()) -> None:
        self.workers = workers
        self.preload = tuple(preload)
        self._pool: ProcessPoolExecutor | None = None
        self._lifeline: Lifeline | None = None

    def _get_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            start_forkserver(self.workers, self.preload)
            ctx = multiprocessing.get_context("forkserver")
            self._lifeline = Lifeline(ctx)
            self._pool = ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=ctx,
                initializer=_start_worker,
                initargs=(worker_init, self._lifeline.reader, list(sys.path)),
            )
        return self._pool

    def start(self) -> None:
        """Launch the forkserver (it imports the tasks' modules in the background; workers fork on the first task)."""
        with signals_deferred():
            self._get_pool()

    def run_tasks(
        self, fn: Callable[..., T], args: Sequence[tuple[object, ...]], labels: Sequence[str]
    ) -> Iterator[tuple[int, T]]:
        if not args:
            return
        futures: dict[Future[T], int] = {}
        try:
            with signals_deferred():  # workers start here: none is left half-started by an interrupt
                pool = self._get_pool()
                futures.update((pool.submit(guarded, fn, labels[i], False, *a), i) for i, a in enumerate(args))
            yield from collect(
                futures,
                labels,
                as_completed(futures),
                lambda f: f.result(),
                lambda fs: [f.cancel() for f in fs],
                BrokenProcessPool,
            )
        except BaseException as err:
            if not isinstance(err, Exception):  # Ctrl-C, SIGTERM, the caller stopped: end the running tasks now
                self._stop(graceful=False)
            raise
        finally:
            for fut in futures:
                fut.cancel()

    def close(self) -> None:
        self._stop(graceful=True)

    def _stop(self, graceful: bool) -> None:
        """Stop the pool within ``stop_grace_s + 2 kill_after_s`` s (``graceful``: idle workers exit by themselves)."""
        pool, lifeline, self._pool, self._lifeline = self._pool, self._lifeline, None, None
        if pool is None or lifeline is None:
            return
        with signals_deferred():  # a second Ctrl-C must not leave the stop half done
            procs = list(pool._processes.values()) if pool._processes else []  # shutdown() drops them
            manager: threading.Thread | None = getattr(pool, "_executor_manager_thread", None)  # typeshed mistypes it
            calls = getattr(pool, "_call_queue", None)
            pool.shutdown(wait=False, cancel_futures=True)
            if not graceful:
                lifeline.cut()
                end_processes(procs, hard=False)
            if manager is not None:
                manager.join(self.stop_grace_s if graceful else self.kill_after_s)
            for hard in (False, True):
                if manager is None or not manager.is_alive():
                    break
                log.warning("local pool: workers did not stop in time, sending %s", "SIGKILL" if hard else "SIGTERM")
                _unblock(calls)
                end_processes(procs, hard=hard)
                manager.join(self.kill_after_s)
            lifeline.cut()


def _start_worker(init: Callable[[Connection], None], lifeline: Connection, sys_path: list[str]) -> None:
    """Pool initialiser: ``init(lifeline)`` (``worker_init``), then the entries of ``sys_path`` the worker lacks.

    ``sys_path`` is this process's module path when it made the pool, which may have grown
    since the forkserver started (a plug-in's folder added while the scenario was checked).
    """
    init(lifeline)
    sys.path.extend(p for p in sys_path if p not in sys.path)


def _unblock(calls: object) -> None:
    """Close the reading end of the pool's call queue, so its feeder thread stops writing to workers that are gone.

    What the standard library's own ``terminate_broken`` does; without it the pool's manager
    thread (joined at exit) waits for ever on a pipe nobody reads.
    """
    try:
        getattr(calls, "_reader").close()  # noqa: B009 (a private attribute of the pool's queue)
    except (AttributeError, OSError):
        pass


def open_executor(cfg: ExecutorConfig | None, preload: Sequence[str] = ()) -> Executor:
    """The executor ``cfg`` describes (``None``: serial). A local pool of one worker runs in-process.

    ``preload``: what a local pool's forkserver loads before it forks a worker (``start_forkserver``).
    """
    if cfg is None or cfg.kind == "serial":
        return SerialExecutor()
    if cfg.kind == "local":
        n = cfg.n_workers()
        return SerialExecutor() if n == 1 else LocalPoolExecutor(n, preload)
    from roman_sim.runner.dask_executor import DaskExecutor

    return DaskExecutor(cfg)


__all__ = [
    "Executor",
    "ExecutorConfig",
    "LocalPoolExecutor",
    "SerialExecutor",
    "TaskError",
    "guarded",
    "open_executor",
    "prestart",
    "start_forkserver",
    "thread_limits",
    "threads_per_worker",
    "worker_name",
]
