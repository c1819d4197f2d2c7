"""A small typed registry for closed choices (aligners, presets, segmenters, ...).

Unknown names raise ``ConfigError`` listing the valid ones. Names of the form
``package.module:Attr`` are imported, so users can plug their own implementations.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Callable, Iterator
from types import ModuleType
from typing import Generic, TypeVar, overload

from roman_sim.core.errors import ConfigError

T = TypeVar("T")


class Registry(Generic[T]):
    """Maps names to factories; ``get`` resolves built-in names and ``module:Attr`` paths."""

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._items: dict[str, T] = {}

    @overload
    def register(self, name: str, item: None = None) -> Callable[[T], T]: ...

    @overload
    def register(self, name: str, item: T) -> T: ...

    def register(self, name: str, item: T | None = None) -> Callable[[T], T] | T:
        """Register ``item`` under ``name``; usable as a decorator."""
        if item is not None:
            self._items[name] = item
            return item

        def deco(obj: T) -> T:
            self._items[name] = obj
            return obj

        return deco

    def names(self) -> list[str]:
        """Registered names, sorted."""
        return sorted(self._items)

    def __contains__(self, name: object) -> bool:
        return name in self._items

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def get(self, name: str) -> T:
        """The item called ``name`` (or imported from ``package.module:Attr``)."""
        if name in self._items:
            return self._items[name]
        if ":" in name:
            return import_object(name, self.kind)  # type: ignore[return-value]
        raise ConfigError(f"unknown {self.kind} {name!r} (valid: {', '.join(self.names())}, or package.module:Name)")


def import_object(path: str, kind: str = "object") -> object:
    """Import ``package.module:Attr``; any failure raises ``ConfigError`` in one line.

    The module is looked up on ``sys.path``, then in the current folder (which is appended
    to ``sys.path`` for that: ``examples.my_aligner:MyAligner`` works from a checkout without
    setting ``PYTHONPATH``, also under the ``roman-sim`` console script).
    """
    mod_name, _, attr = path.partition(":")
    if not mod_name or not attr:
        raise ConfigError(f"{kind} {path!r}: expected package.module:Name")
    try:
        module = _import_module(mod_name)
    except ImportError as err:
        raise ConfigError(f"{kind} {path!r}: cannot import {mod_name!r}: {one_line(err)}") from None
    except Exception as err:  # a plug-in's module may raise anything while it is imported
        raise ConfigError(
            f"{kind} {path!r}: importing {mod_name!r} raised {type(err).__name__}: {one_line(err)}"
        ) from None
    obj: object = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ConfigError(f"{kind} {path!r}: {mod_name!r} has no attribute {attr!r}")
        obj = getattr(obj, part)
    return obj


def _import_module(mod_name: str) -> ModuleType:
    try:
        return importlib.import_module(mod_name)
    except ModuleNotFoundError as err:
        top = mod_name.split(".")[0]
        cwd = os.getcwd()
        on_path = {os.path.abspath(p or os.curdir) for p in sys.path}
        here = os.path.isdir(os.path.join(cwd, top)) or os.path.isfile(os.path.join(cwd, f"{top}.py"))
        if err.name != top or cwd in on_path or not here:
            raise
        sys.path.append(cwd)
        importlib.invalidate_caches()
        return importlib.import_module(mod_name)


def one_line(err: BaseException, limit: int = 300) -> str:
    """An exception's message on one line, at most ``limit`` characters."""
    text = " ".join(str(err).split()) or type(err).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."
