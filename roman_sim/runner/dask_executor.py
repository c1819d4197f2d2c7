"""The Dask executor: tasks on an existing scheduler or on a local cluster bound to loopback.

A local cluster (no ``scheduler_address``) listens on 127.0.0.1 only, one single-threaded
worker process per worker, with no dashboard unless ``dashboard`` is set (then on
127.0.0.1, a free port). Results come back to this process, which writes every file, so
workers need no access to the run folder.

The local cluster's worker processes die with this process however it ends: ``distributed``
starts each with a pipe to its parent and the worker exits when that pipe closes. ``close``
is bounded (``close_timeout_s`` for the client, then for the cluster, whose nannies end
workers that do not stop) and runs with SIGINT and SIGTERM held back, so a second Ctrl-C
does not leave it half done.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, TypeVar, cast

from roman_sim.core.errors import ClusterError, RomanSimError
from roman_sim.runner.executor_base import Executor, ExecutorConfig, TaskError, collect, guarded

if TYPE_CHECKING:
    from distributed import Client, Future, LocalCluster
    from distributed.security import Security

log = logging.getLogger(__name__)

T = TypeVar("T")


def connect_client(address: str, timeout_s: float, security: Security | None = None) -> Client:
    """A ``distributed.Client`` connected to ``address`` within ``timeout_s`` (one-line error otherwise).

    Plain ``tcp://`` goes through ``roman_sim.runner.cluster.connect`` (a bounded handshake
    probe, then an identity check: ports that are not Dask schedulers fail in one line);
    ``tls://`` connects with ``security``, bounded by the client's own timeout.
    """
    from roman_sim.runner.cluster import connect, start_client

    if security is None and address.strip().startswith("tcp://"):
        return connect(address, timeout_s=timeout_s)
    try:
        return start_client(address, timeout_s, security)
    except Exception as err:  # distributed raises OSError, TimeoutError or the remote side's errors
        msg = " ".join(str(err).split())[:240]
        raise ClusterError(f"Dask scheduler {address}: cannot connect: {type(err).__name__}: {msg}") from None


def _result(fut: Future) -> object:
    """A future's result; errors of the cluster itself (a lost worker, an unpicklable result) as ``TaskError``."""
    try:
        return fut.result()
    except _RERAISE:
        raise
    except Exception as err:
        if type(err).__name__ == "CancelledError":
            raise
        raise TaskError(f"{type(err).__name__}: {' '.join(str(err).split())[:240]}") from None


try:
    from distributed.scheduler import KilledWorker as _KilledWorker

    _LOST: tuple[type[BaseException], ...] = (_KilledWorker,)
except ImportError:  # distributed is optional until a Dask executor is built
    _LOST = ()

#: Errors ``_result`` passes on unchanged: the library's own and a lost worker's.
_RERAISE: tuple[type[BaseException], ...] = (RomanSimError, *_LOST)


class DaskExecutor(Executor):
    """Tasks on a Dask cluster (see the module docstring)."""

    kind = "dask"
    #: Bound on closing the client, then the local cluster (s).
    close_timeout_s = 10.0

    def __init__(self, cfg: ExecutorConfig) -> None:
        from roman_sim.runner import dask_security as sec
        from roman_sim.runner.lifeline import signals_deferred

        self.cfg = cfg
        self.cluster: LocalCluster | None = None
        self.client: Client | None = None
        security = sec.security_for(cfg)
        address = sec.check_address(cfg.scheduler_address, cfg, security) if cfg.scheduler_address else None
        if address is None:
            with signals_deferred():  # an interrupt now would leave a cluster nobody can close
                self.cluster = sec.local_cluster(cfg, security)
        try:
            target = address if address is not None else str(cast("LocalCluster", self.cluster).scheduler_address)
            self.client = connect_client(target, cfg.connect_timeout_s, security)
            self.workers = max(1, len(self.client.scheduler_info().get("workers", {})))
            for path in cfg.upload:
                sec.upload(self.client, path)
        except BaseException:
            self.close()
            raise
        log.info("Dask executor: %s, %d worker(s)", self.address, self.workers)

    @property
    def address(self) -> str:
        """The scheduler's address."""
        return str(self._connected().scheduler.address)  # type: ignore[union-attr]  # a connected client has one

    def _connected(self) -> Client:
        """The client (``ClusterError`` once the executor is closed)."""
        if self.client is None:
            raise ClusterError("the Dask executor is closed")
        return self.client

    def run_tasks(
        self, fn: Callable[..., T], args: Sequence[tuple[object, ...]], labels: Sequence[str]
    ) -> Iterator[tuple[int, T]]:
        from distributed import as_completed

        if not args:
            return
        client = self._connected()
        futures = {client.submit(guarded, fn, labels[i], True, *a, pure=False): i for i, a in enumerate(args)}
        try:
            done = collect(
                futures, labels, as_completed(list(futures), loop=client.loop), _result, client.cancel, _LOST
            )
            yield from cast(Iterator[tuple[int, T]], done)  # each future holds its task's T
        finally:
            client.cancel([f for f in futures if not f.done()])

    def check_imports(self, modules: Sequence[str]) -> None:
        from roman_sim.runner import dask_security as sec

        sec.check_worker_imports(self._connected(), list(modules))

    def close(self) -> None:
        from roman_sim.runner.lifeline import signals_deferred

        cluster, client, self.cluster, self.client = self.cluster, self.client, None, None
        with signals_deferred():
            try:
                if client is not None:
                    client.close(timeout=self.close_timeout_s)
            except Exception as err:  # a scheduler already gone, a timeout: the cluster is still closed below
                log.warning("Dask client did not close cleanly: %s: %s", type(err).__name__, err)
            finally:
                if cluster is not None:
                    _close_cluster(cluster, self.close_timeout_s)


def _close_cluster(cluster: LocalCluster, timeout_s: float) -> None:
    """Close a local cluster within about ``timeout_s``; its workers die with this process if that fails."""
    try:
        cluster.close(timeout=timeout_s)
    except Exception as err:  # a timeout or a nanny's own error while stopping
        log.warning("Dask local cluster did not close in time: %s: %s", type(err).__name__, err)
