"""A local pool's preload: modules, warm-ups and listed entries loaded once in the forkserver, best effort."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from roman_sim.runner import preload as pl

PLUGIN = """
CALLS = []
MORE = ("json", "{name}:warm")


def warm():
    CALLS.append("warm")


def broken():
    raise RuntimeError("no solver here")
"""


@pytest.fixture
def module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """A throwaway importable module: a warm-up, a failing warm-up and a list of further entries."""
    name = f"preload_probe_{os.getpid()}_{tmp_path.name}".replace("-", "_")
    (tmp_path / f"{name}.py").write_text(PLUGIN.format(name=name), encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield name
    sys.modules.pop(name, None)


def test_entries_are_imported_called_and_expanded_and_failures_are_named(module: str) -> None:
    failed = pl.preload((module, f"{module}:MORE", f"{module}:broken", "no_such_module_xyz", f"{module}:missing"))
    assert failed == [f"{module}:broken", "no_such_module_xyz", f"{module}:missing"]
    assert sys.modules[module].CALLS == ["warm"]  # called once, through the listed entry


def test_the_environment_carries_the_entries_once_and_a_capped_process_preloads_nothing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv(pl.PRELOAD_ENV, "json,,os.path")
    monkeypatch.setattr(pl, "capped", lambda: False)
    assert pl.from_environment() == ("json", "os.path")
    assert pl.PRELOAD_ENV not in os.environ  # workers forked from the forkserver do not inherit it
    monkeypatch.setenv(pl.PRELOAD_ENV, "json")
    monkeypatch.setattr(pl, "capped", lambda: True)
    assert pl.from_environment() == ()


def test_pool_workers_fork_with_the_preload_loaded(module: str, tmp_path: Path) -> None:
    # its own process: the forkserver starts once per process, with the settings of its first pool
    script = textwrap.dedent(
        f"""
        import os, sys
        sys.path.insert(0, {str(tmp_path)!r})
        from roman_sim.runner.executors import LocalPoolExecutor
        from roman_sim.runner.preload import PRELOAD_ENV

        def probe(_):
            m = sys.modules.get({module!r})
            return (m is not None and m.CALLS == ["warm"], PRELOAD_ENV in os.environ)

        if __name__ == "__main__":
            with LocalPoolExecutor(2, ({module!r} + ":MORE",)) as ex:
                print(sorted(set(ex.map(probe, [(i,) for i in range(4)], [str(i) for i in range(4)]))))
            print(PRELOAD_ENV in os.environ)
        """
    )
    path = tmp_path / "pool.py"
    path.write_text(script, encoding="utf-8")
    out = subprocess.run([sys.executable, str(path)], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.split("\n")[:2] == ["[(True, False)]", "False"], out.stderr
