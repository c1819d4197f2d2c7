"""A lock file's holder is recognised by its pid, start time and command line, not by its pid alone.

Each case writes a lock file no process holds (as a killed run, a copy or a hand leaves it)
and takes the folder over: the warning says what became of the recorded holder.
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import psutil
import pytest

from roman_sim.pipeline import folder_lock
from roman_sim.pipeline.folder_lock import LOCK_NAME, Holder, hold_run_folder


@pytest.fixture
def sleeper() -> Iterator[subprocess.Popen[bytes]]:
    """A live process that is not a run and holds no lock."""
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    yield proc
    proc.kill()
    proc.wait()


def _take_over(folder: Path, text: str, caplog: pytest.LogCaptureFixture) -> list[str]:
    """Write ``text`` as the folder's lock file, take the lock, return the warnings."""
    folder.mkdir(exist_ok=True)
    (folder / LOCK_NAME).write_text(text, encoding="utf-8")
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger=folder_lock.__name__):
        with hold_run_folder(folder) as lock:
            assert Holder.parse(lock.read_text(encoding="utf-8")) == Holder.of(os.getpid())
    return [r.getMessage() for r in caplog.records]


def test_a_holder_is_its_pid_start_time_and_command_line(sleeper: subprocess.Popen[bytes]) -> None:
    h = Holder.of(sleeper.pid)
    assert h is not None and h.pid == sleeper.pid
    assert h.cmd == " ".join(psutil.Process(sleeper.pid).cmdline())
    ticks = os.sysconf("SC_CLK_TCK")
    boot = psutil.boot_time()
    assert h.start is not None and abs(boot + h.start / ticks - psutil.Process(sleeper.pid).create_time()) < 1.0
    assert Holder.parse(h.text()) == h
    assert Holder.parse("1234\n") == Holder(1234)
    assert Holder.parse("") is None and Holder.parse("not a pid\n") is None


def test_a_copied_lock_naming_a_live_process_that_is_not_a_run(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A lock file that names pid 1 alone: pid 1 runs, holds nothing, and is not said to have ended."""
    (msg,) = _take_over(tmp_path / "run", "1\n", caplog)
    assert msg.startswith(f"{tmp_path / 'run'}: taking over the lock of run pid 1: the lock file records only a pid")
    assert "no longer runs" not in msg and "holds no lock on this folder" in msg


def test_a_lock_whose_pid_now_belongs_to_another_process(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, sleeper: subprocess.Popen[bytes]
) -> None:
    now = Holder.of(sleeper.pid)
    assert now is not None and now.start is not None
    earlier = replace(now, start=now.start - 1, cmd="roman-sim run demo")  # the recorded run started before it
    (msg,) = _take_over(tmp_path / "run", earlier.text(), caplog)
    assert msg == (
        f"{tmp_path / 'run'}: taking over the lock of run pid {sleeper.pid} (roman-sim run demo), which no longer "
        f"runs: pid {sleeper.pid} is now another process ({now.cmd}, started after it)"
    )


def test_a_lock_of_a_live_process_that_holds_no_lock(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, sleeper: subprocess.Popen[bytes]
) -> None:
    """The recorded process itself still runs (a lock file copied from its folder)."""
    now = Holder.of(sleeper.pid)
    assert now is not None
    (msg,) = _take_over(tmp_path / "run", now.text(), caplog)
    assert msg == (
        f"{tmp_path / 'run'}: taking over the lock of run pid {sleeper.pid} ({now.cmd}): that process still runs "
        "but holds no lock on this folder (a copied lock file?)"
    )


def test_a_lock_of_a_process_that_ended(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    recorded = Holder.of(proc.pid)
    proc.kill()
    proc.wait()
    assert recorded is not None
    (msg,) = _take_over(tmp_path / "run", recorded.text(), caplog)
    head = f"{tmp_path / 'run'}: taking over the lock of run pid {proc.pid}"
    assert msg == f"{head} ({recorded.cmd}), which no longer runs"


def test_a_lock_of_another_boot(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, sleeper: subprocess.Popen[bytes]
) -> None:
    now = Holder.of(sleeper.pid)
    assert now is not None
    (msg,) = _take_over(tmp_path / "run", replace(now, boot="another-boot").text(), caplog)
    assert "recorded on another boot or machine: no process here holds it" in msg


def test_without_proc_a_holder_is_its_pid_alone(
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
    sleeper: subprocess.Popen[bytes],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """On a system without /proc the pid is all there is, and the warning says so."""
    recorded = Holder.of(sleeper.pid)
    monkeypatch.setattr(folder_lock, "_PROC", tmp_path / "no-proc")
    assert Holder.of(sleeper.pid) == Holder(sleeper.pid)
    assert Holder.of(os.getpid()) == Holder(os.getpid(), cmd=folder_lock._cut(" ".join(sys.orig_argv)))
    assert recorded is not None
    (msg,) = _take_over(tmp_path / "run", recorded.text(), caplog)
    assert msg.endswith("a holder is recognised by its pid alone: the lock file is stale or copied)")
    assert f"pid {sleeper.pid} runs but holds no lock on this folder" in msg


def test_nothing_is_said_of_a_lock_file_this_process_wrote(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    me = Holder.of(os.getpid())
    assert me is not None
    assert _take_over(tmp_path / "run", me.text(), caplog) == []
    assert _take_over(tmp_path / "run", "", caplog) == []  # a lock file that records nobody


def test_the_lock_removes_only_the_empty_folders_it_made(tmp_path: Path) -> None:
    kept = tmp_path / "kept"
    kept.mkdir()
    with hold_run_folder(kept / "a" / "b"):
        assert (kept / "a" / "b" / LOCK_NAME).is_file()
    assert sorted(kept.iterdir()) == []  # a and b were made by the lock, and were empty again
    with hold_run_folder(kept / "a" / "b"):
        (kept / "a" / "b" / "out.txt").write_text("x", encoding="utf-8")
    assert sorted(p.name for p in (kept / "a" / "b").iterdir()) == ["out.txt"]
    with hold_run_folder(kept):
        pass
    assert kept.is_dir()  # it was there before: never removed
