"""What a local pool's forkserver imports before it forks a worker: the modules its tasks use.

A pool given a preload (``roman_sim.runner.executors.start_forkserver``) names this module as
its forkserver's preload and passes the entries in the environment variable ``PRELOAD_ENV``
(read and removed here, so workers do not inherit it). Every worker is then forked with those
modules already imported (seconds of CPU each), and the forkserver imports them while the
process that started it works on. An entry is

- ``module``: imported;
- ``module:name``: imported, then ``name`` is called if it is a function (a warm-up, e.g.
  loading a compiled solver) or, if it is a sequence of entries, those are preloaded in turn.
  So a command can start the forkserver before it imports the code that lists the preload.

Best effort: an entry that fails (a missing optional package, a capped address space) is
skipped, and the task that needs it imports it itself and fails there with its own error.
Under a capped address space (``ulimit -v``) nothing is preloaded: every worker is forked
with the forkserver's address space, and a preload would leave a worker little of the cap
for its work. Nothing here starts a thread or an OpenGL context. The preload stops (and the
forkserver exits) as soon as the process that started the forkserver is gone, so a command
that stops early leaves no process importing.
"""

from __future__ import annotations

import importlib
import logging
import os
from collections.abc import Sequence

log = logging.getLogger(__name__)

#: The environment variable that carries a pool's preload entries (comma-separated) to its forkserver.
PRELOAD_ENV = "ROMAN_SIM_WORKER_PRELOAD"


def capped() -> bool:
    """Whether this process's address space is capped (``ulimit -v``)."""
    try:
        import resource

        return resource.getrlimit(resource.RLIMIT_AS)[0] != resource.RLIM_INFINITY
    except (ImportError, ValueError, OSError):  # no such limit here
        return False


def _orphaned(parent: int) -> None:
    """Exit at once when the process that started this one is gone (this one was re-parented)."""
    if os.getppid() != parent:
        os._exit(0)


def preload(entries: Sequence[str]) -> list[str]:
    """Load every entry (see the module docstring); the entries that failed."""
    parent = os.getppid()
    failed: list[str] = []
    for entry in entries:
        _load(entry, parent, failed)
    _orphaned(parent)
    return failed


def _load(entry: str, parent: int, failed: list[str]) -> None:
    _orphaned(parent)
    module, _, name = entry.partition(":")
    try:
        found: object = importlib.import_module(module)
        if name:
            found = getattr(found, name)
            if callable(found):
                found = found()
            elif isinstance(found, (tuple, list)):
                for inner in found:
                    _load(str(inner), parent, failed)
    except Exception as err:  # noqa: BLE001 (best effort: the task that needs it reports the error)
        failed.append(entry)
        log.debug("preload of %s failed: %s: %s", entry, type(err).__name__, err)


def from_environment() -> tuple[str, ...]:
    """The entries ``PRELOAD_ENV`` names (removed from the environment), none under a capped address space."""
    raw = os.environ.pop(PRELOAD_ENV, "")
    return () if capped() else tuple(e for e in raw.split(",") if e)


preload(from_environment())  # in the forkserver; elsewhere ``PRELOAD_ENV`` is unset and nothing is loaded
