"""The test extra installs what the tests import: no test skips for a missing package on a fresh clone."""

from __future__ import annotations

import ast
import tomllib
from importlib.metadata import PackageNotFoundError, packages_distributions, requires
from pathlib import Path

from packaging.requirements import Requirement
from readme_commands import TEST, marked_command, no_deps_installs

ROOT = Path(__file__).resolve().parent.parent


def _name(requirement: Requirement) -> str:
    """A requirement's distribution name, normalised (``kiss-matcher`` -> ``kiss_matcher``)."""
    return requirement.name.lower().replace("-", "_")


def _optional_imports() -> set[str]:
    """Top-level modules the tests import through ``pytest.importorskip``."""
    out = set()
    for path in (ROOT / "tests").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "importorskip" and node.args:
                arg = node.args[0]
                if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                    out.add(arg.value.split(".")[0])
    return out - {"roman_sim"}


def _installed_by(extra: str) -> set[str]:
    """Distributions the project and its ``extra`` install, with what those depend on (installed ones)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    todo = [Requirement(r) for r in project["dependencies"] + project["optional-dependencies"][extra]]
    seen: set[str] = set()
    while todo:
        req = todo.pop()
        if _name(req) in seen:
            continue
        seen.add(_name(req))
        try:
            deps = [Requirement(r) for r in requires(req.name) or []]
        except PackageNotFoundError:  # not installed here: its own dependencies are unknown, the name still counts
            continue
        env = [{"extra": e} for e in req.extras] or [{"extra": ""}]
        todo += [d for d in deps if d.marker is None or any(d.marker.evaluate(e) for e in env)]
    return seen


def _installed_apart() -> set[str]:
    """Distributions the README's test command (CI runs it) installs with ``pip install --no-deps NAME==VERSION``.

    Their other dependencies are in the test extra (robotdatapy would pull opencv-python).
    """
    return {_name(Requirement(r)) for r in no_deps_installs(marked_command(TEST))}


def test_every_optional_import_of_the_tests_is_in_the_test_extra():
    dists = {k: {d.lower().replace("-", "_") for d in v} for k, v in packages_distributions().items()}
    wanted = _optional_imports()
    assert {"evo", "kiss_matcher"} <= wanted  # the cross-checks this guards
    installed = _installed_by("test") | _installed_apart()
    missing = {m for m in wanted if not (dists.get(m, {m}) & installed)}
    assert not missing, f"tests import {sorted(missing)}, which the test extra does not install"
