"""One run per results folder: an exclusive lock held for the run's whole life.

``hold_run_folder(run_dir)`` takes an advisory ``flock`` on ``run_dir/.run.lock`` and writes
the holder's process id into it; a second run into the same folder raises ``RunFolderBusy``
at once, naming the folder and the holder's pid, instead of mixing its files with the
first run's. The kernel drops a ``flock`` when its holder dies, however it dies, so a lock
file left by a killed run (SIGKILL, a crash, a lost machine) holds no lock: the next run
takes it over, with a warning naming the dead holder's pid. The file is removed when the run
ends, so a finished run folder holds only the run's own files.

Removing the file while other processes may have it open would let two of them lock two
different files of the same name; so after locking, the holder checks that the path still
names the file it locked, and retries when it does not.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import logging
import os
from collections.abc import Iterator
from pathlib import Path

from roman_sim.core.errors import ConfigError, RunFolderBusy

log = logging.getLogger(__name__)

#: The lock file inside a run folder while a run writes into it.
LOCK_NAME = ".run.lock"


def _holder(fd: int) -> str:
    """The pid recorded in an open lock file (``unknown`` if it holds none)."""
    try:
        text = os.pread(fd, 64, 0).decode("ascii", "replace").strip()
    except OSError:
        return "unknown"
    return text if text.isdigit() else "unknown"


def _lock_once(path: Path) -> int | None:
    """The fd of ``path`` locked by this process, or None when the path was replaced meanwhile."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            if err.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise
            raise RunFolderBusy(
                f"{path.parent} is in use by another run (pid {_holder(fd)}): wait for it to end or write "
                "into another folder"
            ) from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if not same:  # the previous holder removed the file after we opened it
            os.close(fd)
            return None
        stale = _holder(fd)
        if stale != "unknown" and int(stale) != os.getpid():
            log.warning("%s: taking over the lock of run pid %s, which no longer runs", path.parent, stale)
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
        return fd
    except BaseException:
        with contextlib.suppress(OSError):
            os.close(fd)
        raise


@contextlib.contextmanager
def hold_run_folder(run_dir: str | Path) -> Iterator[Path]:
    """Hold ``run_dir``'s exclusive lock for the ``with`` block (the folder is created if needed).

    Raises:
        RunFolderBusy: another live process holds the lock (the message names it by pid).
        ConfigError: the folder cannot be created or written.
    """
    d = Path(run_dir)
    path = d / LOCK_NAME
    try:
        d.mkdir(parents=True, exist_ok=True)
        fd = None
        while fd is None:
            fd = _lock_once(path)
    except OSError as err:
        raise ConfigError(f"--out {d}: cannot write there ({err.strerror or err})") from None
    try:
        yield path
    finally:
        with contextlib.suppress(OSError):
            path.unlink()  # while still locked: a waiting opener of this file sees it replaced
        os.close(fd)


__all__ = ["LOCK_NAME", "RunFolderBusy", "hold_run_folder"]
