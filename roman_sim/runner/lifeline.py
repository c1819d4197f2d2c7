"""Worker processes that cannot outlive their run, and a pool stop that cannot hang.

A local pool's workers are children of multiprocessing's forkserver, not of the run's main
process, and each worker holds the forkserver's "alive" pipe and the resource tracker's
pipe open: once the main process is gone, workers, forkserver and resource tracker keep one
another alive for ever. So every worker watches a *lifeline*: the reading end of a pipe whose
only writing end the main process holds. When the main process ends in any way (an
exception, SIGTERM, SIGKILL), the kernel closes that end, the worker's watcher thread reads
end-of-file and the worker kills itself; the forkserver and the resource tracker then see
their pipes close and exit. The worker also asks Linux for SIGKILL when its parent (the
forkserver) dies (``prctl(PR_SET_PDEATHSIG)``; a no-op elsewhere) and ignores SIGINT: a
Ctrl-C to the terminal's process group reaches the main process, which ends the workers
itself (no traceback from every worker).

On the main side, ``signals_deferred`` holds SIGINT and SIGTERM back while a worker is being
started or the pool is being stopped (an interrupt there would leave a half-started worker
nobody knows of, or a stop half done) and delivers them right after; ``sigint_ignored``
starts the forkserver with SIGINT ignored.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from multiprocessing.connection import Connection
from multiprocessing.context import BaseContext
from typing import Protocol

log = logging.getLogger(__name__)

#: ``PR_SET_PDEATHSIG`` of ``<linux/prctl.h>``.
PR_SET_PDEATHSIG = 1
#: The signals a run stops on (Ctrl-C, a batch scheduler's end of job).
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Stoppable(Protocol):
    """What ``stop_processes`` needs of a ``multiprocessing`` process."""

    def terminate(self) -> None: ...

    def kill(self) -> None: ...


def set_parent_death_signal(sig: int = signal.SIGKILL) -> bool:
    """Have Linux send ``sig`` to this process when the thread that started it ends; False where unsupported."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return int(libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


class Lifeline:
    """The main process's end of the workers' lifeline (see the module docstring)."""

    def __init__(self, ctx: BaseContext) -> None:
        self.reader, self._writer = ctx.Pipe(duplex=False)

    def cut(self) -> None:
        """Close the writing end: every worker past its initialiser kills itself at once."""
        if not self._writer.closed:
            self._writer.close()


def worker_init(lifeline: Connection) -> None:
    """Pool worker initialiser: ignore SIGINT, die with the forkserver, die when ``lifeline`` closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    set_parent_death_signal(signal.SIGKILL)
    threading.Thread(target=_watch, args=(lifeline,), name="roman-sim-lifeline", daemon=True).start()


def _watch(lifeline: Connection) -> None:
    """Block until the main process closes its end (or dies), then kill this process."""
    try:
        while True:
            lifeline.recv_bytes()
    except (EOFError, OSError):
        pass
    os.kill(os.getpid(), signal.SIGKILL)


@contextmanager
def signals_deferred(signals: Sequence[int] = STOP_SIGNALS) -> Iterator[None]:
    """Hold ``signals`` back inside the block (main thread only) and deliver the first one after it.

    A signal whose handler was not set from Python is left alone. Delivered again with
    ``signal.raise_signal`` once the old handlers are back, so it acts as it would have.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    old = {s: h for s in signals if (h := signal.getsignal(s)) is not None}
    try:
        for s in old:
            signal.signal(s, lambda signum, _frame: held.append(signum))
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        if held:
            signal.raise_signal(held[0])


@contextmanager
def sigint_ignored() -> Iterator[None]:
    """SIGINT ignored inside the block (main thread only): processes started here begin with it ignored.

    A signal ignored at ``exec`` stays ignored in the new program, so multiprocessing's
    forkserver and resource tracker, started here, cannot be interrupted by a Ctrl-C to the
    process group while they import (a traceback each). A SIGINT that arrives inside the
    block, a few milliseconds, is lost.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


@contextmanager
def parent_sys_path() -> Iterator[None]:
    """``PYTHONPATH`` set to this process's ``sys.path`` inside the block, for a forkserver started there.

    Python 3.11's forkserver ignores the ``sys_path`` it is given and imports its preload
    modules with the default path of a new interpreter, whose first entry is the current
    folder: after a ``chdir`` (or with a checkout that is not the installed copy) the workers
    would run another copy of the package than this process. With the environment variable
    the forkserver resolves modules in the same order as this process.
    """
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join(os.path.abspath(p) if p else os.getcwd() for p in sys.path)
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = old


def end_processes(procs: Sequence[Stoppable], hard: bool) -> None:
    """Send SIGTERM (``hard``: SIGKILL) to every process of ``procs`` (those already gone are skipped)."""
    for p in procs:
        try:
            p.kill() if hard else p.terminate()
        except (OSError, ValueError, AttributeError):  # already reaped, closed or never started
            continue


__all__ = [
    "STOP_SIGNALS",
    "Lifeline",
    "end_processes",
    "parent_sys_path",
    "set_parent_death_signal",
    "sigint_ignored",
    "signals_deferred",
    "worker_init",
]
