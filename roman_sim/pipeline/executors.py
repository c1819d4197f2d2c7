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
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, TypeVar

from roman_sim.pipeline.executor_base import (
    Executor,
    ExecutorConfig,
    TaskError,
    collect,
    guarded,
    worker_name,
)

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor

log = logging.getLogger(__name__)

T = TypeVar("T")


class SerialExecutor(Executor):
    """Every task in this process, one after the other (errors unchanged)."""

    def run_tasks(
        self, fn: Callable[..., T], args: Sequence[tuple[object, ...]], labels: Sequence[str]
    ) -> Iterator[tuple[int, T]]:
        for i, a in enumerate(args):
            yield i, fn(*a)


class LocalPoolExecutor(Executor):
    """A pool of worker processes on this machine (``forkserver``: no threads or GL state are forked)."""

    kind = "local"

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self._pool: ProcessPoolExecutor | None = None

    def _get_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(["roman_sim.pipeline.tasks"])
            self._pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx)
        return self._pool

    def run_tasks(
        self, fn: Callable[..., T], args: Sequence[tuple[object, ...]], labels: Sequence[str]
    ) -> Iterator[tuple[int, T]]:
        from concurrent.futures import as_completed
        from concurrent.futures.process import BrokenProcessPool

        if not args:
            return
        pool = self._get_pool()
        futures = {pool.submit(guarded, fn, labels[i], False, *a): i for i, a in enumerate(args)}
        try:
            yield from collect(
                futures,
                labels,
                as_completed(futures),
                lambda f: f.result(),
                lambda fs: [f.cancel() for f in fs],
                BrokenProcessPool,
            )
        finally:
            for fut in futures:
                fut.cancel()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


def open_executor(cfg: ExecutorConfig | None) -> Executor:
    """The executor ``cfg`` describes (``None``: serial). A local pool of one worker runs in-process."""
    if cfg is None or cfg.kind == "serial":
        return SerialExecutor()
    if cfg.kind == "local":
        n = cfg.n_workers()
        return SerialExecutor() if n == 1 else LocalPoolExecutor(n)
    from roman_sim.pipeline.dask_executor import DaskExecutor

    return DaskExecutor(cfg)


__all__ = [
    "Executor",
    "ExecutorConfig",
    "LocalPoolExecutor",
    "SerialExecutor",
    "TaskError",
    "guarded",
    "open_executor",
    "worker_name",
]
