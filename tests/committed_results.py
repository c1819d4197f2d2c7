"""The committed results the tests read: an explicit list of folders, never a glob over ``results/``.

``roman-sim demo``, ``roman-sim run`` and the testing helpers write a user's own run folders
under ``results/`` (``results/demo/seed1-<hash>/``, ``results/smoke/...``): they are not the
project's results and no test may collect them. Every test that reads committed results
takes them from the roots below, the folders ``.gitignore`` keeps under version control
(``tests/test_committed_results.py`` checks that the two lists agree), and lists files only
through ``committed_files``, which also leaves out what a root's own ``.gitignore`` names
(the benchmark's ``work/`` run folders).
"""

from __future__ import annotations

import fnmatch
import shutil
from collections.abc import Iterable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "results"
#: ``roman-sim reproduce``: the paper's experiments and the demo.
REFERENCE = RESULTS / "reference"
#: ``roman-sim benchmark standard``.
STANDARD = RESULTS / "benchmark" / "standard"
#: ``roman-sim study attribution --results results/attribution``.
ATTRIBUTION = RESULTS / "attribution"
#: Every committed result root.
COMMITTED_ROOTS = (REFERENCE, STANDARD, ATTRIBUTION)
#: The committed measurements of ``benchmarks/`` (its ``*.json`` files; read by name).
BENCHMARKS_OUT = ROOT / "benchmarks" / "out"


def _ignored_folders(root: Path) -> set[str]:
    """The folders a root's own ``.gitignore`` leaves out (lines such as ``work/``)."""
    ignore = root / ".gitignore"
    if not ignore.is_file():
        return set()
    lines = (ln.strip() for ln in ignore.read_text(encoding="utf-8").splitlines())
    return {ln.strip("/") for ln in lines if ln and not ln.startswith(("#", "!"))}


def committed_files(pattern: str = "*", roots: Iterable[Path] = COMMITTED_ROOTS) -> list[Path]:
    """The files under ``roots`` whose names match ``pattern`` (recursively), sorted.

    A folder the root's ``.gitignore`` names is skipped, as git skips it.
    """
    out = []
    for root in roots:
        skip = _ignored_folders(root)
        for path in root.rglob(pattern):
            if path.is_file() and path.relative_to(root).parts[0] not in skip:
                out.append(path)
    return sorted(out)


def copy_committed(root: Path, dest: Path, ignore: Iterable[str] = ()) -> Path:
    """Copy the committed files of ``root`` into ``dest`` (same relative paths), but names matching ``ignore``."""
    patterns = tuple(ignore)
    for path in committed_files(roots=[root]):
        if not any(fnmatch.fnmatch(path.name, p) for p in patterns):
            target = dest / path.relative_to(root)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, target)
    return dest
