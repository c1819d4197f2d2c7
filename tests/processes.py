"""Finding the processes a run leaves behind (psutil), for the interrupt and orphan tests.

A run's processes are found by an environment variable every descendant inherits (the
forkserver, its workers, the resource tracker, Dask's workers), so orphans that were
re-parented to init are found too.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import psutil

ROOT = Path(__file__).resolve().parents[1]
TAG = "ROMAN_SIM_TEST_RUN_TAG"
#: Standard-library helpers that live as long as the process that started them, not per pool.
HELPERS = ("multiprocessing.forkserver", "multiprocessing.resource_tracker")


def tagged_env(**extra: str) -> tuple[dict[str, str], str]:
    """An environment for a child run (this checkout first on the path) and the tag that marks its processes."""
    tag = uuid.uuid4().hex
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "MUJOCO_GL": "egl",
        "PYOPENGL_PLATFORM": "egl",
        TAG: tag,
        **extra,
    }
    return env, tag


def tagged(tag: str) -> list[psutil.Process]:
    """Live (not zombie) processes whose environment carries ``tag``."""
    out = []
    for p in psutil.process_iter():
        try:
            if p.status() != psutil.STATUS_ZOMBIE and p.environ().get(TAG) == tag:
                out.append(p)
        except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
            continue
    return out


def wait_gone(find: object, timeout_s: float = 10.0) -> list[str]:
    """Poll ``find()`` (a list of processes) until it is empty or ``timeout_s`` passed; what is left, described."""
    deadline = time.monotonic() + timeout_s
    while True:
        left = find()  # type: ignore[operator]
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.1)
    return [_describe(p) for p in left]


def pool_workers(baseline: set[int]) -> list[psutil.Process]:
    """Live descendants of this process that are neither in ``baseline`` nor a standard-library helper."""
    out = []
    for p in psutil.Process().children(recursive=True):
        try:
            if p.pid in baseline or p.status() == psutil.STATUS_ZOMBIE:
                continue
            if any(h in " ".join(p.cmdline()) for h in HELPERS):
                continue
            out.append(p)
        except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
            continue
    return out


def _describe(p: psutil.Process) -> str:
    try:
        return f"{p.pid} {' '.join(p.cmdline())[:120]}"
    except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
        return str(p.pid)


def start(cmd: list[str], env: dict[str, str], cwd: Path | None = None) -> subprocess.Popen[str]:
    """A child in its own process group (so a group signal can be sent), SIGINT at its default."""
    return subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=cwd,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def cli(*args: str) -> list[str]:
    """The command line of ``roman-sim ARGS`` with this interpreter."""
    return [sys.executable, "-m", "roman_sim.cli", *args]
