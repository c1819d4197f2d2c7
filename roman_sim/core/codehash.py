"""Fingerprints of source code: the static import closure of some modules, hashed.

``code_closure(roots, skip)`` reads the roots' source files and follows their imports
statically (``ast``; nothing is imported or run): every ``import`` and ``from ... import``
anywhere in a module, lazy ones inside functions included, except those under
``if TYPE_CHECKING:``. It follows the modules of the roots' own top-level packages (for
this package: ``roman_sim``; for a plug-in ``mypkg.mod:Class``: ``mypkg`` and ``roman_sim``)
and every other module whose source lies outside the installed libraries (the standard
library and the site-packages folders): a helper module beside a plug-in is code the
plug-in runs, whatever its name. Installed libraries are not hashed: their versions are
(below).

- ``from pkg import name`` follows ``pkg.name`` when that is a module, else the module
  ``pkg/__init__.py`` takes ``name`` from (its re-export), else ``pkg/__init__.py``
  itself. The ``__init__`` of a package is not followed merely because one of its
  submodules is imported: what it registers as a side effect is not code the importer
  runs.
- ``skip`` names modules (a name covers its submodules) that are neither hashed nor
  followed (code that does not decide results, such as where tasks run); ``shallow``
  modules are hashed but their imports are not followed (configuration models, whose
  values reach a cache key anyway).

``code_fingerprint(roots, skip)`` is 16 hex digits of SHA-256 over the closure's module
names and source bytes, in sorted order, and over ``library_versions``: Python's version and
the installed version of every distribution that provides a top-level module the closure
imports (``numpy``, ``mujoco``, ``cv2`` -> ``opencv-python-headless``, ...). So code made with
other library versions gets another fingerprint, and whatever is keyed by it is computed
again. It is deterministic, independent of the folder the package is installed in, and
cheap (each file is read and parsed once per process while its size and modification time
stay the same).

Imports made by name at run time (``importlib.import_module(some_string)``) cannot be seen
statically and are not followed.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import platform
import site
import sys
import sysconfig
from collections.abc import Iterable
from functools import cache
from importlib import metadata
from pathlib import Path
from typing import Any

#: The package whose modules every closure may follow.
HOME = "roman_sim"


def _top(name: str) -> str:
    return name.split(".", 1)[0]


@cache
def _package_dir(top: str) -> Path | None:
    """Folder of the top-level package ``top`` (or of the single-file module ``top.py``); None when unknown."""
    mod = sys.modules.get(top)
    origin = getattr(mod, "__file__", None) if mod is not None else None
    if origin is None:
        try:
            spec = importlib.util.find_spec(top)
        except (ImportError, ValueError):
            return None
        origin = spec.origin if spec is not None else None
    if not origin:
        return None
    path = Path(origin)
    return path.parent if path.name == "__init__.py" else path


@cache
def module_file(name: str) -> Path | None:
    """Source file of the module ``name`` (``pkg/mod.py`` or ``pkg/mod/__init__.py``), None when there is none."""
    base = _package_dir(_top(name))
    if base is None:
        return None
    if base.is_file():  # a single-file top-level module
        return base if "." not in name else None
    rel = Path(*name.split(".")[1:])
    for cand in (base / rel / "__init__.py", (base / rel).with_suffix(".py") if rel.parts else None):
        if cand is not None and cand.is_file():
            return cand
    return None


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


def _import_nodes(stmts: list[Any]) -> Iterable[ast.Import | ast.ImportFrom]:
    """The import statements among ``stmts`` and those nested in their bodies (an import is a statement).

    ``stmts`` are statements, except handlers and match cases (which have bodies too).
    """
    for node in stmts:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        elif isinstance(node, ast.If) and _is_type_checking(node):
            yield from _import_nodes(node.orelse)
        else:
            for field in ("body", "orelse", "finalbody", "handlers", "cases"):
                sub = getattr(node, field, None)
                if isinstance(sub, list):
                    yield from _import_nodes(sub)


@cache
def _parsed(path: Path, size: int, mtime_ns: int) -> tuple[bytes, tuple[tuple[str, tuple[str, ...]], ...]]:
    """The file's bytes and its imports as (module, names imported from it); cached per file version."""
    data = path.read_bytes()
    try:
        tree = ast.parse(data, filename=str(path))
    except SyntaxError:  # hashed all the same; its imports cannot be followed
        return data, ()
    is_pkg = path.name == "__init__.py"
    out: list[tuple[str, tuple[str, ...]]] = []
    for node in _import_nodes(tree.body):
        if isinstance(node, ast.Import):
            out += [(a.name, ()) for a in node.names]
        else:
            out.append((_absolute(node, path, is_pkg), tuple(a.name for a in node.names)))
    return data, tuple(out)


def _absolute(node: ast.ImportFrom, path: Path, is_pkg: bool) -> str:
    """The absolute module name of ``from <module> import ...`` (relative imports resolved from the file's place)."""
    if not node.level:
        return node.module or ""
    # the package holding ``path``: its folder's dotted name below the top-level package
    parts: list[str] = []
    folder = path.parent
    while (folder / "__init__.py").is_file():
        parts.insert(0, folder.name)
        folder = folder.parent
    up = node.level - 1
    pkg = parts[: len(parts) - up] if up else parts
    return ".".join([*pkg, *([node.module] if node.module else [])])


def _source(name: str) -> tuple[bytes, tuple[tuple[str, tuple[str, ...]], ...]] | None:
    path = module_file(name)
    if path is None:
        return None
    st = path.stat()
    return _parsed(path, st.st_size, st.st_mtime_ns)


def _reexport(pkg: str, name: str, depth: int = 0) -> str:
    """The module ``pkg`` takes ``name`` from (``from X import name`` in its ``__init__``), else ``pkg``."""
    src = _source(pkg)
    if src is None or depth > 8:
        return pkg
    for module, names in src[1]:
        if name not in names:
            continue
        if module_file(f"{module}.{name}") is not None:
            return f"{module}.{name}"
        path = module_file(module)
        if path is None:
            return pkg
        return _reexport(module, name, depth + 1) if path.name == "__init__.py" and module != pkg else module
    return pkg


def _edges(name: str) -> set[str]:
    src = _source(name)
    if src is None:
        return set()
    out: set[str] = set()
    for module, names in src[1]:
        path = module_file(module)
        if not names or path is None:
            out.add(module)
            continue
        for n in names:
            sub = f"{module}.{n}"
            if module_file(sub) is not None:
                out.add(sub)
            else:
                out.add(_reexport(module, n) if path.name == "__init__.py" else module)
    return out


def _skipped(name: str, skip: Iterable[str]) -> bool:
    return any(name == s or name.startswith(s + ".") for s in skip)


def code_closure(roots: Iterable[str], skip: Iterable[str] = (), shallow: Iterable[str] = ()) -> list[str]:
    """The modules ``roots`` import statically, themselves included, sorted (see the module docstring).

    ``shallow`` modules are included when reached, but their imports are not followed.
    """
    return sorted(_walk(tuple(roots), tuple(skip), frozenset(shallow))[0])


@cache
def _installed_dirs() -> tuple[Path, ...]:
    """The folders of installed code: the standard library and every site-packages folder."""
    paths = sysconfig.get_paths()
    dirs = {paths[k] for k in ("stdlib", "platstdlib", "purelib", "platlib") if k in paths}
    dirs |= set(site.getsitepackages()) | {site.getusersitepackages()}
    return tuple(sorted({Path(d).resolve() for d in dirs if d}))


@cache
def is_installed(top: str) -> bool:
    """Whether the top-level module ``top`` is an installed library (or not found at all)."""
    where = _package_dir(top)
    if where is None:
        return True
    path = where.resolve()
    return any(path.is_relative_to(d) for d in _installed_dirs())


def _walk(roots: tuple[str, ...], skip: tuple[str, ...], shallow: frozenset[str]) -> tuple[set[str], set[str]]:
    """The closure's modules and the top-level names of the installed libraries they import."""
    roots = tuple(r for r in roots if module_file(r) is not None and not _skipped(r, skip))
    follow = {HOME} | {_top(r) for r in roots}
    seen: set[str] = set()
    libraries: set[str] = set()
    todo = list(roots)
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        src = _source(name)
        libraries |= {_top(m) for m, _ in (src[1] if src else ()) if m and _top(m) not in follow}
        if name in shallow:
            continue
        for e in _edges(name):
            top = _top(e)
            if e in seen or _skipped(e, skip) or module_file(e) is None:
                continue
            if top in follow or not is_installed(top):
                todo.append(e)
    libraries = {t for t in libraries if t not in {_top(m) for m in seen} and is_installed(t)}
    return seen, libraries


@cache
def _distributions() -> dict[str, tuple[str, ...]]:
    """Top-level module name -> the installed distributions that provide it."""
    return {top: tuple(sorted(set(d))) for top, d in metadata.packages_distributions().items()}


@cache
def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def library_versions(tops: Iterable[str]) -> dict[str, str]:
    """Python's version and ``distribution -> version`` of the distributions providing the modules ``tops``.

    Standard-library modules and modules no installed distribution provides are left out.
    """
    out = {"python": platform.python_version()}
    dists = _distributions()
    for top in tops:
        for dist in dists.get(top, ()):
            version = _version(dist)
            if version is not None:
                out[dist] = version
    return dict(sorted(out.items()))


def code_libraries(roots: Iterable[str], skip: Iterable[str] = (), shallow: Iterable[str] = ()) -> dict[str, str]:
    """``library_versions`` of the installed libraries that ``code_closure(roots, skip, shallow)`` imports."""
    return library_versions(_walk(tuple(roots), tuple(skip), frozenset(shallow))[1])


def code_fingerprint(roots: Iterable[str], skip: Iterable[str] = (), shallow: Iterable[str] = ()) -> str:
    """16 hex digits of SHA-256 over the names and sources of ``code_closure(roots, skip, shallow)``
    and the versions of the installed libraries it imports (``code_libraries``)."""
    modules, libraries = _walk(tuple(roots), tuple(skip), frozenset(shallow))
    h = hashlib.sha256()
    for name in sorted(modules):
        src = _source(name)
        assert src is not None  # the closure keeps only modules with a source file
        h.update(name.encode("utf-8") + b"\0" + hashlib.sha256(src[0]).digest())
    for dist, version in library_versions(libraries).items():
        h.update(f"\0{dist}=={version}".encode())
    return h.hexdigest()[:16]
