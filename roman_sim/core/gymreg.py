"""Registers ``roman_sim/GroundRobot-v0`` with gymnasium without importing gymnasium early.

``import roman_sim`` calls ``install()``: when gymnasium is already imported the environment
is registered at once; otherwise a finder on ``sys.meta_path`` waits for gymnasium's own
import, registers the environment right after it, and removes itself. So
``import roman_sim; import gymnasium; gymnasium.make("roman_sim/GroundRobot-v0")`` works,
while ``import roman_sim.mapping`` stays free of gymnasium (and of MuJoCo: the entry point
is a string, the environment module loads on the first ``make``).
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import sys
from types import ModuleType
from typing import Any

ENV_ID = "roman_sim/GroundRobot-v0"
ENTRY_POINT = "roman_sim.sim.env:GroundRobotEnv"


def register_env() -> None:
    """Register the environment with gymnasium (imports gymnasium; idempotent)."""
    import gymnasium as gym

    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point=ENTRY_POINT)


class _RegisterAfterImport(importlib.abc.MetaPathFinder):
    """Finds gymnasium with the other finders and registers the environment once it is loaded."""

    def find_spec(self, name: str, path: Any = None, target: ModuleType | None = None) -> Any:
        if name != "gymnasium":
            return None
        uninstall()
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None:
            spec.loader = _Loader(spec.loader)
        return spec


class _Loader(importlib.abc.Loader):
    """Runs the real loader, restores it on the module, then registers the environment."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
        return self.inner.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        self.inner.exec_module(module)
        if module.__spec__ is not None:
            module.__spec__.loader = self.inner
        module.__loader__ = self.inner
        register_env()


_FINDER = _RegisterAfterImport()


def install() -> None:
    """Register now if gymnasium is loaded, else as soon as it is imported."""
    if "gymnasium" in sys.modules:
        register_env()
    elif _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)


def uninstall() -> None:
    """Remove the import hook (registration already done, or no longer wanted)."""
    if _FINDER in sys.meta_path:
        sys.meta_path.remove(_FINDER)
