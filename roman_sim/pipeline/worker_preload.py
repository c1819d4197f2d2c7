"""What a run's local pool's forkserver imports before it forks a worker: the modules the run's tasks use.

A run's local pool names this module as the forkserver's preload
(``roman_sim.runner.executors.RUN_PRELOAD``). Every worker is forked from the forkserver
with these modules already imported and the compiled CLIPPER solver loaded, so no worker
does that again (seconds of CPU each), and the forkserver does it while the run's own
process imports and generates the world. Best effort: a module that fails to import here (a
missing optional package, a capped address space) is skipped, and the task that needs it
imports it itself and fails there with its own error. Under a capped address space
(``ulimit -v``) only the tasks' own module is preloaded: every worker is forked with the
forkserver's address space, and a full preload would leave a worker little of the cap for
its work. Nothing here starts a thread or an OpenGL context. The preload stops (and the
forkserver exits) as soon as the process that started the forkserver is gone, so a command
that stops early leaves no process importing.
"""

from __future__ import annotations

import importlib
import logging
import os

log = logging.getLogger(__name__)

#: What mapping, alignment and plotting tasks import (the world's modules too: a pool task
#: receives the world pickled).
MODULES = (
    "roman_sim.pipeline.tasks",
    "roman_sim.pipeline.context",
    "roman_sim.pipeline.robot_mapping",
    "roman_sim.world",
    "roman_sim.sim.robot",
    "roman_sim.sim.render",
    "roman_sim.align",
    "roman_sim.align.clipper_jit",
    "roman_sim.align.visual.aligner",
    "roman_sim.report.render",
    "roman_sim.report.examples",
    "roman_sim.report.trajplot",
    "cv2",
)


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


def preload(modules: tuple[str, ...] = MODULES, warm: bool = True) -> list[str]:
    """Import ``modules`` and (``warm``) load the compiled CLIPPER solver; the names of what failed."""
    parent = os.getppid()
    failed = []
    for name in modules:
        _orphaned(parent)
        try:
            importlib.import_module(name)
        except Exception as err:  # noqa: BLE001 (best effort: the task importing it reports the error)
            failed.append(name)
            log.debug("preload of %s failed: %s: %s", name, type(err).__name__, err)
    _orphaned(parent)
    if not warm:
        return failed
    try:
        from roman_sim.align.clipper import warm_up

        warm_up()  # numba's cache, loaded once here instead of in every worker
    except Exception as err:  # noqa: BLE001 (the first pair a worker aligns loads it, or reports the error)
        failed.append("roman_sim.align.clipper.warm_up")
        log.debug("CLIPPER warm-up failed: %s: %s", type(err).__name__, err)
    return failed


#: What could not be preloaded.
FAILED = preload(MODULES[:1], warm=False) if capped() else preload()
