"""Fixtures of the bad-input suite: a folder of user plug-ins (broken in every way) and input files.

The suite runs from that folder (``chdir``), so ``--aligner user_plugins:Class`` resolves
from the current directory, as a user's would.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

#: Robots of the smoke scenario stop after 12 m: a complete run takes a few seconds.
MICRO = ["--set", "robots.0.max_length_m=12", "--set", "robots.1.max_length_m=12"]

PLUGINS = '''
import numpy as np
from roman_sim.align.base import AlignResult
from roman_sim.mapping.mask import Mask


class RaisesInInit:
    name = "init"
    def __init__(self):
        raise OSError("model weights not found")
    def align(self, a, b): ...


class NoAlign:
    name = "noalign"


def _returns(value):
    class Returns:
        name = "returns"
        def align(self, a, b):
            return value
        def segment(self, frame):
            return value
        def encode(self, crop, mask, ctx):
            return value
    return Returns


ReturnsNone, ReturnsDict, ReturnsStr = _returns(None), _returns({"T_a_b": None}), _returns("aligned")


class AlwaysRaises:
    name = "always"
    def align(self, a, b):
        raise IndexError("list index out of range")
    def segment(self, frame):
        raise IndexError("list index out of range")
    def encode(self, crop, mask, ctx):
        raise IndexError("list index out of range")


class FailsOnRealPairs:
    """Passes the dry call (two submaps of different robots, index 0) and raises on the run's later pairs."""
    name = "late"
    def align(self, a, b):
        if a.index > 0 or b.index > 0 or a.robot == b.robot:
            raise KeyError("segment 17")
        return AlignResult.failure("late", "declines")


class SlowOnRealPairs:
    """Passes the dry call at once and takes 2 s per pair of the run (a window to interrupt the evaluation)."""
    name = "slow"
    def align(self, a, b):
        import time
        if a.index > 0 or b.index > 0 or a.robot == b.robot:
            time.sleep(2.0)
        return AlignResult.failure("slow", "declines")


class FailsOnLaterFrames:
    def segment(self, frame):
        if frame.robot != "check" and frame.index >= 3:
            raise MemoryError("CUDA out of memory")
        return [Mask(frame.depth > 0)]


class UnnormalisedEncoder:
    def encode(self, crop, mask, ctx):
        return np.full(16, 3.0)
'''


@pytest.fixture(scope="session")
def plugin_home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding ``user_plugins.py`` and broken modules."""
    d = tmp_path_factory.mktemp("home")
    (d / "user_plugins.py").write_text(PLUGINS)
    (d / "syntax_error.py").write_text("class Broken(:\n    pass\n")
    (d / "raises_on_import.py").write_text("raise RuntimeError('licence server unreachable')\n")
    (d / "missing_dependency.py").write_text("import torch_that_is_not_installed\n")
    return d


@pytest.fixture
def home(plugin_home: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """Run the test from the plug-in folder."""
    monkeypatch.chdir(plugin_home)
    yield plugin_home
