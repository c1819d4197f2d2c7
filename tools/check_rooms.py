"""Fail when a package leaves its room: over its line budget, a module outside its subjects, tests out of place.

The rooms are ``tools/rooms.toml``: per package of ``roman_sim`` (and the top-level module
``testing``), a line budget and the subjects it may hold, each with the modules that belong to
it. One line per problem, exit code 1 when there is one:

- a package (every line of its ``.py`` files, subpackages included) over its budget;
- a module in no subject of its package: the line names the package whose subject lists it,
  when one does (``roman_sim/evaluation/board_records.py: ... belongs in roman_sim.benchmark``);
- a package or module on disk without a room, or an entry that names no module;
- the test tree not mirroring the package tree: every folder ``tests/<path>/`` is a package
  ``roman_sim/<path>/``; a test file under ``tests/<package>/`` imports from
  ``roman_sim.<package>`` or names it in its text (a script it runs, its docstring); and a test
  file named after a module of another package that it imports (``test_<module>.py``) sits in
  that package's folder, unless its own package has a module of that name too.

Only the standard library: it reads files as text and imports nothing of the package.
"""

from __future__ import annotations

import argparse
import ast
import fnmatch
import re
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

PACKAGE = "roman_sim"
ROOMS = Path("tools") / "rooms.toml"
#: Top-level modules of the package that are a room of their own (others are packages).
MODULE_ROOMS = ("testing",)


@dataclass(frozen=True)
class Room:
    """A package's room: its name, line budget and subjects (subject -> module patterns)."""

    name: str
    budget: int
    subjects: dict[str, list[str]]

    def subject_of(self, module: str, anywhere: bool = True) -> str | None:
        """The subject whose patterns match ``module``; with ``anywhere=False`` a bare ``*`` matches nothing."""
        for subject, patterns in self.subjects.items():
            if any((anywhere or p != "*") and fnmatch.fnmatchcase(module, p) for p in patterns):
                return subject
        return None


class RoomsError(Exception):
    """``tools/rooms.toml`` is malformed (the message names the entry)."""


def read_rooms(path: Path) -> dict[str, Room]:
    """The rooms of ``path`` (``RoomsError`` naming the entry when one is malformed)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise RoomsError(f"{path}: {err}") from None
    packages = data.get("packages")
    if not isinstance(packages, dict) or not packages:
        raise RoomsError(f"{path}: needs [packages.<name>] tables")
    rooms = {}
    for name, entry in packages.items():
        where = f"{path}: packages.{name}"
        budget = entry.get("budget") if isinstance(entry, dict) else None
        subjects = entry.get("subjects") if isinstance(entry, dict) else None
        if not isinstance(budget, int) or isinstance(budget, bool) or budget <= 0:
            raise RoomsError(f"{where}.budget: a positive number of lines is required")
        if not isinstance(subjects, dict) or not subjects:
            raise RoomsError(f"{where}.subjects: a table of subject = [modules] is required")
        for subject, modules in subjects.items():
            if not isinstance(modules, list) or not modules or not all(isinstance(m, str) for m in modules):
                raise RoomsError(f"{where}.subjects.{subject}: a non-empty list of module names is required")
        unknown = sorted(set(entry) - {"budget", "subjects"})
        if unknown:
            raise RoomsError(f"{where}: unknown key {unknown[0]!r} (allowed: budget, subjects)")
        rooms[name] = Room(name, budget, subjects)
    return rooms


def room_files(root: Path, name: str) -> dict[str, Path]:
    """Module name (relative to the room, ``stages/maps``) -> file, ``__init__`` files included."""
    base = root / PACKAGE
    if name in MODULE_ROOMS:
        return {name: base / f"{name}.py"}
    return {p.relative_to(base / name).with_suffix("").as_posix(): p for p in sorted((base / name).rglob("*.py"))}


def rooms_on_disk(root: Path) -> list[str]:
    """The packages of ``roman_sim`` and its top-level modules other than ``__init__``."""
    base = root / PACKAGE
    packages = [p.name for p in base.iterdir() if (p / "__init__.py").is_file()]
    modules = [p.stem for p in base.glob("*.py") if p.stem != "__init__"]
    return sorted(packages + modules)


def _lines(path: Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def _is_init(module: str) -> bool:
    return module == "__init__" or module.endswith("/__init__")


def room_problems(root: Path, rooms: dict[str, Room]) -> list[str]:
    """Budgets exceeded, modules outside their package's subjects, packages without a room, stale entries."""
    out = []
    on_disk = rooms_on_disk(root)
    for name in on_disk:
        if name not in rooms:
            out.append(f"{PACKAGE}/{name}: has no room in {ROOMS} (add its budget and subjects)")
    for name in sorted(set(rooms) - set(on_disk)):
        out.append(f"{ROOMS}: {PACKAGE}.{name} does not exist")
    present = sorted(set(rooms) & set(on_disk))
    modules = {n: {m: p for m, p in room_files(root, n).items() if not _is_init(m)} for n in present}
    strays = [(n, m) for n in present for m in modules[n] if rooms[n].subject_of(m) is None]
    for name in present:
        room = rooms[name]
        lines = sum(_lines(p) for p in room_files(root, name).values())
        if lines > room.budget:
            out.append(
                f"{PACKAGE}.{name}: {lines} lines, over its budget of {room.budget} ({ROOMS}): move out what is "
                "not its subject, or raise the budget and say why"
            )
        out += [_misplaced(n, m, modules[n][m].relative_to(root).as_posix(), rooms) for n, m in strays if n == name]
        for subject, patterns in room.subjects.items():
            for p in patterns:
                found = any(fnmatch.fnmatchcase(m, p) for m in modules[name])
                moved = any(fnmatch.fnmatchcase(m.rsplit("/", 1)[-1], p) for n, m in strays if n != name)
                if not found and not moved:  # a module moved away is named once, by the line above
                    out.append(f"{ROOMS}: {PACKAGE}.{name} ({subject}) lists {p!r}, which names no module of it")
    return out


def _misplaced(name: str, module: str, path: str, rooms: dict[str, Room]) -> str:
    """The line for ``module`` of package ``name``, in none of its subjects: where it belongs, when a room says."""
    leaf = module.rsplit("/", 1)[-1]
    homes = []
    for other in rooms.values():
        if other.name != name:
            subject = other.subject_of(module, anywhere=False) or other.subject_of(leaf, anywhere=False)
            if subject is not None:
                homes.append(f"{PACKAGE}.{other.name} ({subject})")
    if homes:
        return f"{path}: not a subject of {PACKAGE}.{name}; it belongs in {' or '.join(homes)}"
    return (
        f"{path}: in no subject of {PACKAGE}.{name} ({ROOMS}): add it to the subject it serves, or move it to "
        "the package of its subject"
    )


def _imported(tree: ast.AST, root: Path) -> set[str]:
    """The ``roman_sim`` modules a test imports, at any depth (``from pkg import module`` counts the module)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            for alias in node.names:
                full = f"{node.module}.{alias.name}"
                path = root.joinpath(*full.split("."))
                if path.with_suffix(".py").is_file() or (path / "__init__.py").is_file():
                    out.add(full)
        elif isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
    return {m for m in out if m.split(".")[0] == PACKAGE and "." in m}


def mirror_problems(root: Path) -> list[str]:
    """Where ``tests/`` stops mirroring ``roman_sim/`` (see the module docstring)."""
    tests, base = root / "tests", root / PACKAGE
    out = []
    for folder in sorted(p for p in tests.rglob("*") if p.is_dir()):
        rel = folder.relative_to(tests)
        if any(part.startswith((".", "_")) for part in rel.parts):
            continue
        if not (base / rel / "__init__.py").is_file():
            out.append(
                f"tests/{rel.as_posix()}/: {PACKAGE}/{rel.as_posix()}/ is no package (tests/<package>/ mirrors "
                f"{PACKAGE}/<package>/; tests of the repository itself sit in tests/)"
            )
    for path in sorted(tests.rglob("test_*.py")):
        rel = path.relative_to(tests)
        if len(rel.parts) < 2 or any(part.startswith((".", "_")) for part in rel.parts):
            continue
        out += _test_file_problems(root, path, rel.parts[0])
    return out


def _test_file_problems(root: Path, path: Path, pkg: str) -> list[str]:
    """The mirror rules for one test file under ``tests/<pkg>/``."""
    where = path.relative_to(root).as_posix()
    text = path.read_text(encoding="utf-8")
    try:
        tree = ast.parse(text)
    except SyntaxError as err:
        return [f"{where}: cannot be parsed (line {err.lineno}: {err.msg})"]
    own = f"{PACKAGE}.{pkg}"
    modules = _imported(tree, root)
    out = []
    if not any(m == own or m.startswith(own + ".") for m in modules) and not re.search(
        rf"{PACKAGE}[./]{pkg}(?![\w])", text
    ):
        out.append(f"{where}: imports nothing of {own} and names it nowhere: it belongs in the folder of its subject")
    name = path.stem[len("test_") :]
    base = root / PACKAGE / pkg
    if any(p.stem == name or p.parent.name == name for p in base.rglob("*.py")):
        return out  # its own package has a module (or subpackage) of that name
    for m in sorted(modules):
        if m.rsplit(".", 1)[-1] == name and not (m == own or m.startswith(own + ".")):
            home = m.split(".")[1]
            out.append(f"{where}: named after {m}, which it imports: it belongs in tests/{home}/")
            break
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent, help="the repository")
    args = parser.parse_args(argv)
    root = args.root
    try:
        rooms = read_rooms(root / ROOMS)
    except RoomsError as err:
        print(f"error: {err}")
        return 1
    problems = room_problems(root, rooms) + mirror_problems(root)
    for line in problems:
        print(line)
    if not problems:
        print(
            f"rooms: {len(rooms)} rooms within their budgets, every module in a subject of its package; "
            f"tests/ mirrors {PACKAGE}/"
        )
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
