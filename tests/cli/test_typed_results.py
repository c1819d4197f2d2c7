"""The command line reads typed results: no JSON blob crosses into ``roman_sim.cli`` from a library call.

Every name a CLI module imports from the library (at the top or inside a command) is
followed through its annotations: a function's return type, a class's dataclass fields and
the return types of its public methods and properties, and so on through every dataclass,
container and union they reach. None of them may be a JSON blob: ``dict`` / ``Mapping`` with
``Any``, ``object`` or JSON values, or the ``JSON`` / ``JSONLike`` / ``JSONObject`` aliases. The
annotations are resolved with the module's ``TYPE_CHECKING`` imports, and one that does not
resolve fails the test (so nothing escapes the check unread). Configuration models (pydantic)
are inputs the CLI builds, not results: their own methods are followed, their fields are not
(plug-in parameters are free-form by design).
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import types
import typing
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import pytest
from pydantic import BaseModel

import roman_sim
from roman_sim.core.jsontypes import JSON, JSONLike, JSONObject

CLI = Path(roman_sim.__file__).parent / "cli"
BLOBS = (JSON, JSONLike, JSONObject)
ALIASES = ("JSON", "JSONLike")


def _library_imports(path: Path) -> Iterator[tuple[str, str]]:
    """``(module, name)`` of every ``from roman_sim.X import name`` in ``path`` outside the CLI package."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("roman_sim"):
            if not node.module.startswith("roman_sim.cli"):
                yield from ((node.module, a.name) for a in node.names)


def _checking_names(module: types.ModuleType) -> dict[str, Any]:
    """The names a module imports under ``if TYPE_CHECKING:`` (its annotations may use them)."""
    out: dict[str, Any] = {}
    source = inspect.getsource(module)
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for imp in node.body:
                if isinstance(imp, ast.ImportFrom) and imp.module:
                    src = importlib.import_module(imp.module)
                    out.update({a.asname or a.name: getattr(src, a.name) for a in imp.names})
    return out


def _hints(obj: Any) -> dict[str, Any]:
    """``obj``'s resolved annotations (the JSON aliases' own recursive references resolved too)."""
    module = inspect.getmodule(obj)
    assert module is not None, obj
    return typing.get_type_hints(obj, localns={"JSON": JSON, "JSONLike": JSONLike, **_checking_names(module)})


def _is_blob(tp: Any) -> bool:
    """A JSON alias (resolved annotations expand it: its recursive reference remains), or a
    mapping to ``Any`` / ``object``."""
    if any(tp is b for b in BLOBS) or (isinstance(tp, typing.ForwardRef) and tp.__forward_arg__ in ALIASES):
        return True
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (dict, Mapping) and len(args) == 2 and args[1] in (Any, object):
        return True
    return any(_is_blob(a) for a in args if a is not Ellipsis)


class _Walk:
    """Every place a JSON blob reaches the caller, as ``path: type`` (following the classes and
    functions of the modules under ``package``)."""

    def __init__(self, package: str = "roman_sim") -> None:
        self.package = package
        self.seen: set[int] = set()
        self.found: list[str] = []

    def own(self, obj: Any) -> bool:
        module = inspect.getmodule(obj)
        return module is not None and module.__name__.startswith(self.package)

    def type(self, tp: Any, where: str) -> None:
        if _is_blob(tp):
            self.found.append(f"{where}: {tp}")
            return
        if isinstance(tp, type) and self.own(tp):
            self.cls(tp, where)
            return
        for a in typing.get_args(tp):
            if a is not Ellipsis and not isinstance(a, (str, int, bool)):
                self.type(a, where)

    def function(self, fn: Any, where: str) -> None:
        hints = _hints(fn)
        if "return" in hints:
            self.type(hints["return"], f"{where}()")

    def cls(self, cls: type, where: str) -> None:
        if id(cls) in self.seen:
            return
        self.seen.add(id(cls))
        if dataclasses.is_dataclass(cls):
            hints = _hints(cls)
            for f in dataclasses.fields(cls):
                self.type(hints[f.name], f"{where}.{f.name}")
        for name, member in inspect.getmembers(cls):
            if name.startswith("_"):
                continue
            fn = member.fget if isinstance(member, property) else member
            if (inspect.isfunction(fn) or inspect.ismethod(fn)) and self.own(fn):
                self.function(fn, f"{where}.{name}")


def _imported() -> list[tuple[str, str, str]]:
    return sorted({(p.name, m, n) for p in CLI.glob("*.py") for m, n in _library_imports(p)})


@pytest.mark.parametrize(("cli", "module", "name"), _imported(), ids=lambda v: v)
def test_what_the_cli_imports_returns_no_json_blob(cli: str, module: str, name: str) -> None:
    obj = getattr(importlib.import_module(module), name)
    walk = _Walk()
    if inspect.isfunction(obj):
        walk.function(obj, f"{module}.{name}")
    elif isinstance(obj, type) and walk.own(obj) and not issubclass(obj, BaseModel):
        walk.cls(obj, f"{module}.{name}")
    elif isinstance(obj, type) and issubclass(obj, BaseModel):
        for attr, member in vars(obj).items():  # a configuration model: its own methods only
            if inspect.isfunction(member) and not attr.startswith("_"):
                walk.function(member, f"{module}.{name}.{attr}")
    elif walk.own(type(obj)):  # an instance (a registry): what its methods return
        walk.cls(type(obj), f"{module}.{name}")
    assert not inspect.ismodule(obj), f"{cli} imports the module {module}.{name}: import the names it uses"
    assert not walk.found, f"{cli} reads untyped results: " + "; ".join(f[:200] for f in walk.found)


@dataclasses.dataclass
class _Row:
    figures: dict[str, Any]
    count: int


class _Result:
    def rows(self) -> list[_Row | None]:
        return []

    @property
    def table(self) -> dict[str, list[int]]:
        return {}


def test_the_check_finds_a_blob_through_a_method_and_a_dataclass() -> None:
    walk = _Walk(__name__)
    walk.cls(_Result, "Result")
    assert walk.found == ["Result.rows().figures: dict[str, typing.Any]"]
    assert _is_blob(Mapping[str, JSONLike]) and _is_blob(JSON) and _is_blob(dict[str, dict[str, object]])
    assert not _is_blob(dict[str, int]) and not _is_blob(list[str])
