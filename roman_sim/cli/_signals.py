"""How a command stops: on a signal, on a full disk, on a memory limit.

Exit codes: 0 done; 1 an error, printed as one line (``error: ...``); 130 SIGINT (Ctrl-C);
143 SIGTERM (a batch scheduler's end of job); 128 + n when signal n ends the process
outright (139 a segmentation fault, 134 an abort, 137 SIGKILL, e.g. from the kernel's
out-of-memory killer). SIGTERM unwinds the command like Ctrl-C (``Terminated`` is a
``KeyboardInterrupt``): workers are ended, completed stages are kept and the command says
which. A fault in native code (a library crashing under ``ulimit -v``) cannot be caught; the
interpreter's fault handler then prints the Python stack, which names the running stage's
module, before the process ends with 139 or 134.
"""

from __future__ import annotations

import faulthandler
import resource
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

from roman_sim.core.atomic import DISK_FULL, free_space
from roman_sim.core.registry import one_line

#: Exit code of a command stopped by SIGINT (128 + 2).
EXIT_SIGINT = 128 + signal.SIGINT
#: Exit code of a command stopped by SIGTERM (128 + 15).
EXIT_SIGTERM = 128 + signal.SIGTERM


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived: raised in the main thread so the command unwinds as on Ctrl-C."""


def _raise_terminated(signum: int, _frame: FrameType | None) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: the rest of the unwinding is not interrupted again
    raise Terminated()


@contextmanager
def stops_cleanly() -> Iterator[None]:
    """Inside the block SIGTERM raises ``Terminated`` and native faults print the Python stack.

    An inherited ``SIG_IGN`` for SIGTERM is kept. Outside the main thread nothing changes.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.getsignal(signal.SIGTERM)
    install = old == signal.SIG_DFL
    fault = not faulthandler.is_enabled() and _has_fileno(sys.stderr)
    if install:
        signal.signal(signal.SIGTERM, _raise_terminated)
    if fault:
        faulthandler.enable(file=sys.stderr, all_threads=False)
    try:
        yield
    finally:
        if install:
            signal.signal(signal.SIGTERM, old)
        if fault:
            faulthandler.disable()


def _has_fileno(stream: object) -> bool:
    try:
        return isinstance(stream.fileno(), int)  # type: ignore[attr-defined]
    except (AttributeError, OSError, ValueError):  # a test runner's captured stream
        return False


def stop_code(err: KeyboardInterrupt) -> int:
    """The exit code of a command stopped by ``err`` (130 for SIGINT, 143 for SIGTERM)."""
    return EXIT_SIGTERM if isinstance(err, Terminated) else EXIT_SIGINT


def stop_word(err: KeyboardInterrupt) -> str:
    """``interrupted`` (SIGINT) or ``terminated (SIGTERM)``: how the stop line starts."""
    return "terminated (SIGTERM)" if isinstance(err, Terminated) else "interrupted"


def memory_limit_note() -> str | None:
    """``address space limited to 586 MB (ulimit -v)`` when a memory rlimit is set, else None."""
    for name, flag in (("address space", "ulimit -v"), ("data segment", "ulimit -d")):
        limit = getattr(resource, "RLIMIT_AS" if flag.endswith("v") else "RLIMIT_DATA", None)
        if limit is None:
            continue
        soft, _ = resource.getrlimit(limit)
        if soft != resource.RLIM_INFINITY:
            return f"{name} limited to {soft / 2**20:.0f} MB ({flag})"
    return None


def is_disk_full(err: BaseException) -> bool:
    """Whether ``err`` is an ``OSError`` of a full disk or an exhausted quota."""
    return isinstance(err, OSError) and err.errno in DISK_FULL


def disk_full_line(err: OSError, folder: str) -> str:
    """One line for a full disk met outside the atomic writer: the file (when known) and the free space."""
    what = f"writing {err.filename}" if err.filename else "writing"
    return f"{err.strerror or 'no space left on device'} {what} ({free_space(err.filename or folder)} free there)"


def limit_line(err: BaseException, where: str = "") -> str:
    """One line for ``MemoryError`` (or any failure under a memory rlimit); ``where``: e.g. ``in stage maps``.

    Under a memory rlimit the line starts with the cap, then the stage, then what failed:
    whichever library met the cap first (an allocation, a renderer that cannot map its
    device, a thread that cannot start) only shows the symptom.
    """
    what = "out of memory" if isinstance(err, MemoryError) else "failed"
    desc = f"{type(err).__name__}: {one_line(err)}" if str(err).strip() else type(err).__name__
    return capped(f"{what}{' ' + where if where else ''}: {desc}")


def capped(line: str) -> str:
    """``line`` after the memory rlimit in force (``address space limited to 586 MB (ulimit -v): ...``), if any."""
    note = memory_limit_note()
    return f"{note}: {line}" if note else line
