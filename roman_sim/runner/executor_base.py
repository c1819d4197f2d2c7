"""The executor interface and what every executor shares: its configuration, task errors, result collection.

The executors themselves (serial, local process pool, Dask) are in
``roman_sim.runner.executors`` and ``roman_sim.runner.dask_executor``; see the former's
docstring for the contract.
"""

from __future__ import annotations

import logging
import os
import socket
import traceback
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from typing import Literal, TypeVar

from pydantic import Field, field_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError, RomanSimError, keep_worker_traceback

log = logging.getLogger(__name__)

T = TypeVar("T")
F = TypeVar("F")

ExecutorKind = Literal["serial", "local", "dask"]


class TaskError(RomanSimError):
    """A task failed on a worker (the message names the task and the worker)."""


class ExecutorConfig(StrictModel):
    """How a run or sweep spreads its tasks (not part of any result: any setting gives the same bytes)."""

    kind: ExecutorKind = "serial"
    workers: int | None = Field(None, ge=1, le=1024, description="processes / Dask workers (default: cores)")
    scheduler_address: str | None = Field(
        None, description="an existing Dask scheduler (tls://host:8786) instead of a local cluster"
    )
    chunk_pairs: int = Field(32, ge=1, le=100000, description="submap pairs per alignment task")
    connect_timeout_s: float = Field(5.0, gt=0.0, le=600.0, description="bound on reaching the scheduler (s)")
    tls: bool = Field(False, description="local cluster: TLS with temporary certificates; remote: require tls://")
    tls_ca_file: str | None = Field(None, description="CA certificate (PEM) that signed the cluster's certificates")
    tls_cert: str | None = Field(None, description="client certificate (PEM)")
    tls_key: str | None = Field(None, description="client private key (PEM; may be inside tls_cert)")
    insecure: bool = Field(False, description="allow an unauthenticated tcp:// scheduler that is not on loopback")
    dashboard: bool = Field(False, description="local cluster: serve the dashboard on 127.0.0.1 (off by default)")
    upload: list[str] = Field(
        default_factory=list, description="plug-in files (.py, .zip, .egg) uploaded to every Dask worker"
    )

    @field_validator("scheduler_address")
    @classmethod
    def _address(cls, v: str | None) -> str | None:
        if v is None:
            return v
        from roman_sim.runner.cluster import parse_scheduler_address

        try:
            parse_scheduler_address(v)
        except ConfigError as err:
            raise ValueError(str(err)) from None
        return v.strip()

    def n_workers(self) -> int:
        """The worker count (``workers`` or the number of cores)."""
        return self.workers or (os.cpu_count() or 1)


def worker_name() -> str:
    """Who runs this code: the Dask worker's address, else ``host:pid``."""
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return f"{socket.gethostname()}:pid{os.getpid()}"


def guarded(fn: Callable[..., T], label: str, name_worker: bool, *args: object) -> T:
    """Run ``fn(*args)`` on a worker: errors become picklable one-liners (see the module docstring).

    Each carries the worker's tracebacks of the error and of what lay behind it (a plug-in's own
    exception, with its file and line) as text (``core.errors.keep_worker_traceback``): pickling
    keeps no traceback, and ``--debug`` shows these."""
    try:
        return fn(*args)
    except RomanSimError as err:
        if not name_worker:
            keep_worker_traceback(err)
            raise
        raise keep_worker_traceback(TaskError(f"{label} failed on worker {worker_name()}: {err}"), err) from None
    except Exception as err:  # a bug or a plug-in's own error: keep the place it happened
        where = traceback.extract_tb(err.__traceback__)[-1]
        on = f" on worker {worker_name()}" if name_worker else ""
        raise keep_worker_traceback(
            TaskError(
                f"{label} failed{on}: {type(err).__name__}: {err} "
                f"(at {os.path.basename(where.filename)}:{where.lineno})"
            ),
            err,
        ) from None


def collect(
    futures: dict[F, int],
    labels: Sequence[str],
    completed: Iterator[F],
    result: Callable[[F], T],
    cancel: Callable[[list[F]], object],
    lost: type[BaseException] | tuple[type[BaseException], ...],
) -> Iterator[tuple[int, T]]:
    """Yield ``(index, result)`` of finished futures; after a failure cancel the pending ones and,
    once the running ones are done, raise the error of the lowest failed index."""
    failed: dict[int, BaseException] = {}
    for fut in completed:
        i = futures[fut]
        try:
            res = result(fut)
        except lost as err:  # the worker died: not the task's own error
            failed[i] = TaskError(f"{labels[i]}: a worker was lost ({type(err).__name__})")
        except BaseException as err:  # CancelledError is a BaseException for asyncio-based futures
            if type(err).__name__ == "CancelledError":
                continue
            if not isinstance(err, Exception):
                raise
            failed[i] = err
        else:
            yield i, res
            continue
        cancel([f for f, j in futures.items() if j not in failed])
    if failed:
        raise failed[min(failed)]


class Executor(ABC):
    """Runs independent tasks (see the module docstring)."""

    kind: str = "serial"
    workers: int = 1

    @abstractmethod
    def run_tasks(
        self, fn: Callable[..., T], args: Sequence[tuple[object, ...]], labels: Sequence[str]
    ) -> Iterator[tuple[int, T]]:
        """Run ``fn(*args[i])`` for every i; yield ``(i, result)`` as each finishes."""

    def map(self, fn: Callable[..., T], args: Sequence[tuple[object, ...]], labels: Sequence[str]) -> list[T]:
        """The results of every task, in task order."""
        out: dict[int, T] = dict(self.run_tasks(fn, args, labels))
        return [out[i] for i in range(len(args))]

    def start(self) -> None:  # noqa: B027 (optional hook: nothing to start ahead by default)
        """Begin starting the workers now, so their start-up overlaps the caller's own work (no tasks run)."""

    def check_imports(self, modules: Sequence[str]) -> None:  # noqa: B027 (optional hook: workers share this process's imports)
        """Fail (naming the worker and the module) when a worker cannot import one of ``modules``."""

    def close(self) -> None:  # noqa: B027 (optional hook: nothing to release by default)
        """Release the workers."""

    def __enter__(self) -> "Executor":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
