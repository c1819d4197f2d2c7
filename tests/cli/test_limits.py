"""Limits as one line: a full disk, no memory, a memory cap; heavy optional imports load on use only.

The full disk is real where a small tmpfs can be mounted (root, and a system that allows
it), and a patched ``os.fsync`` that fails with ENOSPC on one file everywhere else.
"""

from __future__ import annotations

import errno
import json
import os
import re
import resource
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from processes import cli, tagged, tagged_env, wait_gone

from roman_sim.cli._signals import memory_limit_note

pytestmark = pytest.mark.timeout(300)
MICRO = ["--set", "robots.0.max_length_m=12", "--set", "robots.1.max_length_m=12"]
FREE = r"(\d+ B|\d+\.\d [KMGT]B) free there"
SHORT = ["robots.0.max_length_m=6", "robots.1.max_length_m=6"]


def test_a_full_disk_in_the_evaluation_is_one_line_naming_the_file_and_the_free_space(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, cli_fails
) -> None:
    if not os.path.isdir("/proc/self/fd"):
        pytest.skip("needs /proc/self/fd to tell which file a descriptor writes")
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        if os.readlink(f"/proc/self/fd/{fd}").startswith(str(tmp_path / "run" / ".pairs.csv.")):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    run = tmp_path / "run"
    line = cli_fails("run", "smoke", *MICRO, "--executor", "serial", "--out", run, allow_progress=True)
    assert re.fullmatch(
        rf"error: {re.escape(str(run))}/pairs\.csv: cannot write: no space left on device \({FREE}\) "
        rf"\(completed stages kept in {re.escape(str(run))}: maps, submaps\)",
        line,
    ), line
    assert not list(run.glob(".*.tmp")), "a temporary file was left behind"
    monkeypatch.setattr(os, "fsync", real_fsync)  # space again: the rerun reuses maps and submaps
    from typer.testing import CliRunner

    from roman_sim.cli import app

    res = CliRunner().invoke(app, ["run", "smoke", *MICRO, "--executor", "serial", "--out", str(run)])
    assert res.exit_code == 0, res.output
    timings = json.loads((run / "timings.json").read_text())["stages"]
    assert timings["maps"]["reused"] and timings["submaps"]["reused"] and not timings["evaluation"]["reused"]


@pytest.fixture
def small_tmpfs(tmp_path: Path) -> object:
    """A 512 KB tmpfs mounted on a fresh folder (skip where it cannot be mounted)."""
    where = tmp_path / "disk"
    where.mkdir()
    if shutil.which("mount") is None or os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root and mount(8)")
    res = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(where)], capture_output=True)
    if res.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {res.stderr.decode(errors='replace').strip()}")
    try:
        yield where
    finally:
        if subprocess.run(["umount", str(where)], capture_output=True).returncode != 0:
            subprocess.run(["umount", "-l", str(where)], capture_output=True)


def test_a_run_on_a_full_tmpfs_stops_in_the_maps_stage_with_one_line(small_tmpfs: Path) -> None:
    """The robots' maps (about 1.3 MB) do not fit in 512 KB: the maps stage meets ENOSPC."""
    run = small_tmpfs / "run"
    env, tag = tagged_env()
    res = subprocess.run(cli("run", "smoke", *MICRO, "--out", str(run)), env=env, capture_output=True, text=True)
    assert not wait_gone(lambda: tagged(tag))
    assert res.returncode == 1, res.stderr
    assert "Traceback" not in res.stderr
    line = res.stderr.strip().splitlines()[-1]
    assert re.fullmatch(
        rf"error: {re.escape(str(run))}/\S+: cannot write: no space left on device \({FREE}\) "
        rf"\(no stage completed in {re.escape(str(run))}\)",
        line,
    ), res.stderr
    assert not [p for p in run.rglob("*.tmp")], "a temporary file was left behind"
    assert json.loads((run / "manifest.json").read_text())["stages"] == {}


def test_memory_error_in_a_stage_is_one_line_naming_the_stage(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, cli_fails
) -> None:
    from roman_sim.pipeline.stages import evaluation_job

    def no_memory(*_: object) -> object:
        raise MemoryError("Unable to allocate 8.00 GiB for an array with shape (1073741824,) and data type float64")

    monkeypatch.setattr(evaluation_job, "align_chunk_task", no_memory)
    run = tmp_path / "run"
    line = cli_fails("run", "smoke", *MICRO, "--executor", "serial", "--out", run, allow_progress=True)
    note = memory_limit_note()
    assert line == (
        f"error: {note + ': ' if note else ''}out of memory in stage evaluation: MemoryError: Unable to allocate "
        "8.00 GiB for an array with shape (1073741824,) and data type float64 "
        f"(completed stages kept in {run}: maps, submaps)"
    )


def _capped(kb: int) -> None:
    resource.setrlimit(resource.RLIMIT_AS, (kb * 1024, resource.getrlimit(resource.RLIMIT_AS)[1]))


@pytest.mark.parametrize("executor", ["local", "serial"])
def test_a_run_under_ulimit_v_600000_prints_one_line_with_the_stage_and_the_cap(executor: str, tmp_path: Path) -> None:
    """Rendering cannot start in 586 MB of address space. One line names the stage (or the robot's
    mapping task) and the cap; if a native library crashed instead, the documented exit code is
    139 (134 on abort) with the interpreter's fault report naming the running stage's module."""
    run = tmp_path / "run"
    env, tag = tagged_env()
    res = subprocess.run(
        cli("run", "smoke", *MICRO, "--executor", executor, "--out", str(run)),
        env=env,
        capture_output=True,
        text=True,
        preexec_fn=lambda: _capped(600000),
    )
    assert not wait_gone(lambda: tagged(tag))
    if res.returncode in (-11, -6):  # a segfault or an abort in native code: the fault report
        assert "Fatal Python error" in res.stderr and "roman_sim/pipeline/stages/" in res.stderr, res.stderr
        return
    assert res.returncode == 1, res.stderr
    assert "Traceback" not in res.stderr
    line = res.stderr.strip().splitlines()[-1]
    # the cap first, then the stage, then whatever library met the cap first
    cap = r"error: address space limited to 586 MB \(ulimit -v\): "
    # (with a pool, the cap may be met in a worker or already in the main process while it prepares the world;
    # a worker whose native library aborts at the cap, as OpenBLAS does when its buffers cannot be allocated,
    # is lost to the pool, and the line still names the cap, the stage and the robot's task)
    what = (
        r"(failed in stage maps: mapping robot a( failed: |: a worker was lost \(BrokenProcessPool\))"
        r"|out of memory in stage maps: )"
        if executor == "local"
        else r"(failed|out of memory) in stage maps: "
    )
    assert re.match(cap + what, line), line
    assert line.endswith(f" (no stage completed in {run})"), line


def test_loading_the_pipeline_and_the_cli_imports_neither_opencv_nor_torch() -> None:
    env, _ = tagged_env()
    code = (
        "import sys, roman_sim.pipeline.experiment, roman_sim.cli, roman_sim.align; "
        "print(sorted(m for m in ('cv2', 'torch', 'transformers') if m in sys.modules))"
    )
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "[]"


def test_a_smoke_run_never_imports_torch(tmp_path: Path) -> None:
    """No scenario method of smoke needs a model: torch and transformers stay unloaded for the whole run."""
    env, _ = tagged_env()
    code = (
        "import sys; from roman_sim.pipeline.experiment import run_scenario_file; "
        f"run_scenario_file('smoke', {SHORT!r}, {str(tmp_path / 'run')!r}); "
        "print(sorted(m for m in ('torch', 'transformers') if m in sys.modules))"
    )
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip().splitlines()[-1] == "[]"
