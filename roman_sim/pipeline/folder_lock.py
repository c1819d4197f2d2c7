"""One run per results folder: an exclusive lock held for the run's whole life.

``hold_run_folder(run_dir)`` takes an advisory ``flock`` on ``run_dir/.run.lock`` and writes
the holder into it: its process id, and where the system tells (Linux's ``/proc``) its
start time and command line; a second run into the same folder raises ``RunFolderBusy`` at
once, naming the folder and the holder's pid, instead of mixing its files with the first
run's. The kernel drops a ``flock`` when its holder dies, however it dies, so a lock file left
by a killed run (SIGKILL, a crash, a lost machine) holds no lock: the next run takes it over,
with a warning that says what became of the recorded holder (``stale_holder_note``): gone,
its pid now another process's (started at another time, running another command), or a
live process that holds no lock on the folder (a copied lock file). Without ``/proc`` a
holder is recognised by its pid alone, and the warning says so. The file is removed when the
run ends, so a finished run folder holds only the run's own files; a folder the lock created
is removed again when it is still empty then (a refused or invalid run leaves no folder).

The command line takes the lock first, before its heavy imports and worker pools, so a
refused run answers at once; ``holds_run_folder`` lets the run it then starts see that its
thread already holds the folder.

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
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from roman_sim.core.atomic import output_folder
from roman_sim.core.errors import ConfigError, RunFolderBusy

log = logging.getLogger(__name__)

#: The lock file inside a run folder while a run writes into it.
LOCK_NAME = ".run.lock"
_PROC = Path("/proc")
_CMD_CHARS = 120  # a recorded command line is cut to this length
_HELD: dict[str, int] = {}  # real path of a folder this process holds -> the holding thread's id


@dataclass(frozen=True)
class Holder:
    """A process as a lock file records it.

    Attributes:
        pid: its process id.
        start: its start time in clock ticks after boot (``/proc/<pid>/stat``, field 22);
            None where the system does not tell (no ``/proc``).
        boot: the id of the boot that start time counts from (``/proc/sys/kernel/random/boot_id``).
        cmd: its command line (cut to 120 characters), None where unknown.
    """

    pid: int
    start: int | None = None
    boot: str | None = None
    cmd: str | None = None

    @classmethod
    def of(cls, pid: int) -> Holder | None:
        """The live process ``pid`` as this system describes it; None when no process has that pid."""
        if pid <= 0:
            return None
        stat = _read(_PROC / str(pid) / "stat")
        if stat is None:  # no /proc (or not readable): the pid alone
            if not _alive(pid):
                return None
            return cls(pid, cmd=_cut(" ".join(sys.orig_argv)) if pid == os.getpid() else None)
        try:  # the command name (field 2) may hold spaces and ')': the fields after the last ')'
            start = int(stat.rsplit(")", 1)[1].split()[19])
        except (IndexError, ValueError):
            start = None
        cmdline = _read(_PROC / str(pid) / "cmdline")
        cmd = cmdline.replace("\0", " ") if cmdline else None
        return cls(pid, start, _read(_PROC / "sys" / "kernel" / "random" / "boot_id"), _cut(cmd))

    def text(self) -> str:
        """The lock file's text: the pid on the first line, then ``start``, ``boot`` and ``cmd`` lines."""
        lines = [str(self.pid)]
        for key in ("start", "boot", "cmd"):
            value = getattr(self, key)
            if value is not None:
                lines.append(f"{key} {value}")
        return "\n".join(lines) + "\n"

    @classmethod
    def parse(cls, text: str) -> Holder | None:
        """A holder from a lock file's text (a bare pid too); None when it names no pid."""
        lines = text.splitlines()
        if not lines or not lines[0].strip().isdigit():
            return None
        fields: dict[str, str] = {}
        for ln in lines[1:]:
            key, _, value = ln.partition(" ")
            fields[key] = value
        start = fields.get("start", "").strip()
        return cls(
            int(lines[0]),
            int(start) if start.isdigit() else None,
            fields.get("boot", "").strip() or None,
            fields.get("cmd", "").strip() or None,
        )

    def same_process(self, other: Holder) -> bool | None:
        """Whether ``other`` is this very process (same pid, boot and start time); None when unknown."""
        if self.pid != other.pid:
            return False
        if None in (self.start, self.boot, other.start, other.boot):
            return None
        return self.boot == other.boot and self.start == other.start


def _read(path: Path) -> str | None:
    try:
        return path.read_text(encoding="utf-8", errors="replace").strip()
    except OSError:
        return None


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (portable: signal 0)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # it exists, owned by another user
    except OSError:
        return False
    return True


def _cut(cmd: str | None) -> str | None:
    if not cmd:
        return None
    one = " ".join(cmd.split())
    return one if len(one) <= _CMD_CHARS else one[: _CMD_CHARS - 3] + "..."


def stale_holder_note(folder: Path, recorded: Holder) -> str | None:
    """The warning for taking over a lock file that records ``recorded`` but is held by no process.

    None when there is nothing to say: the file records this very process.
    """
    now = Holder.of(recorded.pid)
    who = f"run pid {recorded.pid}" + (f" ({recorded.cmd})" if recorded.cmd else "")
    head = f"{folder}: taking over the lock of {who}"
    if now is None:
        return f"{head}, which no longer runs"
    same = recorded.same_process(now)
    if same is True:
        if recorded.pid == os.getpid():
            return None
        return f"{head}: that process still runs but holds no lock on this folder (a copied lock file?)"
    now_cmd = now.cmd or "command unknown"
    if same is False and recorded.boot != now.boot:
        return (
            f"{head}, recorded on another boot or machine: no process here holds it "
            f"(pid {recorded.pid} here is another process, {now_cmd})"
        )
    if same is False:
        when = "after" if (now.start or 0) > (recorded.start or 0) else "before"
        return f"{head}, which no longer runs: pid {recorded.pid} is now another process ({now_cmd}, started {when} it)"
    if now.start is None:  # no /proc on this system, or not readable
        return (
            f"{head}: pid {recorded.pid} runs but holds no lock on this folder (its start time cannot be read "
            "here, without /proc, so a holder is recognised by its pid alone: the lock file is stale or copied)"
        )
    if recorded.cmd is not None and recorded.cmd != now.cmd:
        return f"{head}, which no longer runs: pid {recorded.pid} is now another process ({now_cmd})"
    return (
        f"{head}: the lock file records only a pid (no start time), now that of a process that holds no lock "
        f"on this folder ({now_cmd}): the lock file is stale or copied"
    )


def _recorded(fd: int) -> Holder | None:
    """The holder recorded in an open lock file (None if it records none)."""
    try:
        text = os.pread(fd, 4096, 0).decode("utf-8", "replace")
    except OSError:
        return None
    return Holder.parse(text)


def _lock_once(path: Path) -> int | None:
    """The fd of ``path`` locked by this process, or None when the path was replaced meanwhile."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            if err.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise
            holder = _recorded(fd)
            raise RunFolderBusy(
                f"{path.parent} is in use by another run (pid {holder.pid if holder else 'unknown'}): wait for it "
                "to end or write into another folder"
            ) from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if not same:  # the previous holder removed the file after we opened it
            os.close(fd)
            return None
        stale = _recorded(fd)
        note = stale_holder_note(path.parent, stale) if stale is not None else None
        if note is not None:
            log.warning("%s", note)
        me = Holder.of(os.getpid()) or Holder(os.getpid())
        os.ftruncate(fd, 0)
        os.pwrite(fd, me.text().encode("utf-8"), 0)
        return fd
    except BaseException:
        with contextlib.suppress(OSError):
            os.close(fd)
        raise


def _make_folder(d: Path) -> list[Path]:
    """Create ``d`` and its missing parents; the folders this call created, deepest first."""
    missing = []
    p = d
    while not (p.exists() or p.is_symlink()) and p != p.parent:
        missing.append(p)
        p = p.parent
    made = []
    for q in reversed(missing):
        try:
            q.mkdir()
            made.append(q)
        except FileExistsError:
            pass  # another process made it meanwhile
    return made[::-1]


def _remove_if_empty(made: list[Path]) -> None:
    """Remove the folders ``made`` (deepest first) that are still empty; a non-empty one stays."""
    for q in made:
        try:
            q.rmdir()
        except OSError:
            return


def holds_run_folder(run_dir: str | Path) -> bool:
    """Whether this thread holds ``run_dir``'s lock (through ``hold_run_folder``)."""
    return _HELD.get(os.path.realpath(run_dir)) == threading.get_ident()


@contextlib.contextmanager
def hold_run_folder(run_dir: str | Path) -> Iterator[Path]:
    """Hold ``run_dir``'s exclusive lock for the ``with`` block (the folder is created if needed).

    Folders the call created are removed at the end if they are empty then (a run that was
    refused or failed before writing leaves none behind).

    Raises:
        RunFolderBusy: another live process holds the lock (the message names it by pid).
        ConfigError: the folder is a file, cannot be created or cannot be written.
    """
    d = Path(run_dir)
    path = d / LOCK_NAME
    output_folder(d, "--out", create=False)
    made: list[Path] = []
    try:
        made = _make_folder(d)
        fd = None
        while fd is None:
            fd = _lock_once(path)
    except RunFolderBusy:
        _remove_if_empty(made)
        raise
    except OSError as err:
        _remove_if_empty(made)
        raise ConfigError(f"--out {d}: cannot write there ({err.strerror or err})") from None
    key = os.path.realpath(d)
    _HELD[key] = threading.get_ident()
    try:
        yield path
    finally:
        _HELD.pop(key, None)
        with contextlib.suppress(OSError):
            path.unlink()  # while still locked: a waiting opener of this file sees it replaced
        os.close(fd)
        _remove_if_empty(made)


__all__ = ["LOCK_NAME", "Holder", "RunFolderBusy", "hold_run_folder", "holds_run_folder", "stale_holder_note"]
