"""One run per results folder: real ``roman-sim run`` processes racing into one folder.

A run holds an exclusive lock on its folder for its whole life; a second run into it stops
at once with one line naming the folder and the holder's pid; a lock left by a killed run
is taken over. Each run is the smoke scenario with both robots stopping after 12 m.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from processes import cli, start, tagged, tagged_env, wait_gone

from roman_sim.pipeline.folder_lock import LOCK_NAME, Holder
from roman_sim.testing import assert_same_run_folder

pytestmark = pytest.mark.timeout(600)
MICRO = ["--set", "robots.0.max_length_m=12", "--set", "robots.1.max_length_m=12"]
SETTINGS = {"seed0": [], "seed1": ["--set", "seed=1"]}


def _busy_line(out: Path, pid: int) -> str:
    return f"error: {out} is in use by another run (pid {pid}): wait for it to end or write into another folder"


@pytest.fixture(scope="module")
def clean_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One clean run of each setting, alone in its folder."""
    root = tmp_path_factory.mktemp("clean")
    env, _ = tagged_env()
    runs = {}
    for name, extra in SETTINGS.items():
        runs[name] = root / name
        res = subprocess.run(
            cli("run", "smoke", *MICRO, *extra, "--out", str(runs[name])), env=env, capture_output=True, text=True
        )
        assert res.returncode == 0, res.stderr
    return runs


@pytest.fixture
def out(tmp_path: Path) -> Path:
    """The results folder the runs of a test share."""
    return tmp_path / "run"


def _wait_for_lock(out: Path, proc: subprocess.Popen, timeout_s: float = 120.0) -> None:
    """Wait until ``proc`` holds the folder's lock (its pid is in the lock file)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            if (out / LOCK_NAME).read_text().split("\n")[0] == str(proc.pid):
                return
        except OSError:
            pass
        assert proc.poll() is None, f"the run ended before it held the lock: {proc.communicate()}"
        time.sleep(0.02)
    raise AssertionError(f"no lock of pid {proc.pid} in {out} within {timeout_s} s")


@pytest.mark.slow
def test_two_runs_started_together_leave_the_folder_of_one_clean_run(clean_runs: dict[str, Path], out: Path) -> None:
    """Two settings race into one folder: it ends equal to a clean run of the one that ran, never a mix."""
    env, tag = tagged_env()
    procs = {
        name: start(cli("run", "smoke", *MICRO, *extra, "--out", str(out)), env) for name, extra in SETTINGS.items()
    }
    ended = {name: (p, *p.communicate(timeout=300)) for name, p in procs.items()}
    assert not wait_gone(lambda: tagged(tag))
    codes = {name: p.returncode for name, (p, _, _) in ended.items()}
    assert sorted(codes.values()) in ([0, 0], [0, 1]), {n: (c, ended[n][2]) for n, c in codes.items()}
    if 1 in codes.values():  # they overlapped: the loser stopped at once, naming the winner
        loser = next(n for n, c in codes.items() if c == 1)
        winner = next(n for n in codes if n != loser)
        assert ended[loser][2].strip().splitlines() == [_busy_line(out, procs[winner].pid)]
    else:  # one ended before the other took the lock: the later one's results stand
        winner = "seed1" if "seed: 1" in (out / "config.yaml").read_text() else "seed0"
    assert not (out / LOCK_NAME).exists()
    assert_same_run_folder(clean_runs[winner], out)


@pytest.mark.slow
def test_a_run_into_a_locked_folder_stops_at_once_naming_the_holder(clean_runs: dict[str, Path], out: Path) -> None:
    """The holder is paused (SIGSTOP) while it holds the lock, so that on a loaded machine it cannot
    finish before the second run starts; paused, it keeps the lock, and it completes once resumed."""
    env, tag = tagged_env()
    first = start(cli("run", "smoke", *MICRO, "--out", str(out)), env)
    _wait_for_lock(out, first)
    first.send_signal(signal.SIGSTOP)
    try:
        second = subprocess.run(
            cli("run", "smoke", *MICRO, "--set", "seed=1", "--out", str(out)), env=env, capture_output=True, text=True
        )
    finally:
        first.send_signal(signal.SIGCONT)
    assert second.returncode == 1, second.stderr
    assert second.stderr.strip().splitlines() == [_busy_line(out, first.pid)]
    _, err = first.communicate(timeout=300)
    assert first.returncode == 0, err
    assert not wait_gone(lambda: tagged(tag))
    assert_same_run_folder(clean_runs["seed0"], out)


@pytest.mark.slow
def test_the_lock_of_a_killed_run_is_taken_over(clean_runs: dict[str, Path], out: Path) -> None:
    """SIGKILL leaves the lock file with a dead pid; the next run takes it over and completes the folder."""
    env, tag = tagged_env()
    killed = start(cli("run", "smoke", *MICRO, "--out", str(out)), env)
    _wait_for_lock(out, killed)
    killed.send_signal(signal.SIGKILL)
    killed.communicate(timeout=60)
    assert killed.returncode == -signal.SIGKILL
    assert not wait_gone(lambda: tagged(tag))
    left = Holder.parse((out / LOCK_NAME).read_text())  # left behind: no process holds it
    assert left is not None and left.pid == killed.pid and left.cmd is not None and "run smoke" in left.cmd
    res = subprocess.run(cli("run", "smoke", *MICRO, "--out", str(out)), env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert f"taking over the lock of run pid {killed.pid} ({left.cmd}), which no longer runs" in res.stderr
    assert not (out / LOCK_NAME).exists()
    assert_same_run_folder(clean_runs["seed0"], out)


def test_runs_into_different_folders_do_not_wait_for_each_other(tmp_path: Path) -> None:
    """The lock is per folder: holding one does not hold another, and it is released after the block."""
    from roman_sim.core.errors import RunFolderBusy
    from roman_sim.pipeline.folder_lock import hold_run_folder

    code = (
        "import sys\nfrom roman_sim.pipeline.folder_lock import hold_run_folder\n"
        "with hold_run_folder(sys.argv[1]):\n    print('held', flush=True)\n"
    )
    with hold_run_folder(tmp_path / "a") as lock:
        assert Holder.parse(lock.read_text()) == Holder.of(os.getpid())
        env, _ = tagged_env()
        other = subprocess.run(
            [sys.executable, "-c", code, str(tmp_path / "b")], env=env, capture_output=True, text=True
        )
        assert other.returncode == 0 and other.stdout == "held\n", other.stderr
        same = subprocess.run(
            [sys.executable, "-c", code, str(tmp_path / "a")], env=env, capture_output=True, text=True
        )
        assert same.returncode == 1 and "RunFolderBusy" in same.stderr
    assert not (tmp_path / "a" / LOCK_NAME).exists()
    with hold_run_folder(tmp_path / "a"):
        with pytest.raises(RunFolderBusy, match=f"pid {os.getpid()}"):
            with hold_run_folder(tmp_path / "a"):
                pass


#: Run ``roman-sim ARGS`` in this process; at exit, print which of the modules named first were
#: imported, and the number of child processes alive (a worker pool's forkserver is one).
_PROBE = (
    "import atexit, sys, psutil\n"
    "names = sys.argv[1].split(',')\n"
    "def report():\n"
    "    print(','.join(m for m in names if m in sys.modules), flush=True)\n"
    "    print(len(psutil.Process().children(recursive=True)), flush=True)\n"
    "atexit.register(report)\n"
    "from roman_sim.cli import app\n"
    "app(sys.argv[2:], prog_name='roman-sim')\n"
)
#: What a run's start-up imports: the simulator, the pipeline and its stages.
_HEAVY = ("mujoco", "roman_sim.pipeline.experiment", "roman_sim.pipeline.stages")


def _probe(args: list[str], cwd: Path) -> tuple[subprocess.CompletedProcess[str], set[str], int]:
    """``roman-sim ARGS`` in a child process: its result, which of ``_HEAVY`` it imported, its children at exit."""
    env, _ = tagged_env()
    res = subprocess.run(
        [sys.executable, "-c", _PROBE, ",".join(_HEAVY), *args], env=env, cwd=cwd, capture_output=True, text=True
    )
    modules, children = res.stdout.split("\n")[:2]
    return res, set(filter(None, modules.split(","))), int(children)


@pytest.mark.parametrize("executor", ["serial", "local"])
def test_a_refused_run_stops_before_its_start_up_work(tmp_path: Path, executor: str) -> None:
    """With ``--out``: refused before the simulator, the pool or the pipeline starts; the folder untouched."""
    from roman_sim.pipeline.folder_lock import hold_run_folder

    out = tmp_path / "run"
    with hold_run_folder(out) as lock:
        before = lock.read_bytes()
        res, imported, children = _probe(["run", "smoke", "--out", str(out), "--executor", executor], tmp_path)
        assert res.returncode == 1, res.stderr
        assert res.stderr.strip().splitlines() == [_busy_line(out, os.getpid())]
        assert imported == set() and children == 0
        assert lock.read_bytes() == before and sorted(p.name for p in out.iterdir()) == [LOCK_NAME]


def test_a_refused_run_into_its_default_folder_stops_before_the_pool(tmp_path: Path) -> None:
    """The default folder is named by the scenario: it is loaded (the simulator's types with it), nothing more."""
    from roman_sim.pipeline.folder_lock import hold_run_folder
    from roman_sim.pipeline.scenario import default_run_dir, load_scenario

    folder = default_run_dir(load_scenario("smoke"))  # relative: results/smoke/seed0-<hash>
    with hold_run_folder(tmp_path / folder):
        res, imported, children = _probe(["run", "smoke", "--executor", "local"], tmp_path)
    assert res.returncode == 1, res.stderr
    assert res.stderr.strip().splitlines() == [_busy_line(folder, os.getpid())]
    assert imported == {"mujoco"} and children == 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--out", "a/b/run", "--set", "seed=x"], "error: --set seed=x: seed: "),
        (["--aligner", "no_such_module_xyz:Aligner"], "error: "),
    ],
)
def test_a_run_that_fails_validation_leaves_no_folder(tmp_path: Path, args: list[str], message: str) -> None:
    """The lock creates the folder (and its parents) first; a run that then fails removes them again."""
    res, _, _ = _probe(["run", "smoke", *args], tmp_path)
    assert res.returncode == 1, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_an_out_that_is_a_file_is_one_line(tmp_path: Path, cli_fails: Any) -> None:
    """``--out`` naming an existing file: one line before anything runs, the file untouched."""
    target = tmp_path / "notes.txt"
    target.write_text("mine\n", encoding="utf-8")
    err = cli_fails("run", "smoke", "--out", target)
    assert err == f"error: --out {target}: is an existing file, not a folder (choose a folder path)"
    assert target.read_text(encoding="utf-8") == "mine\n"
