"""The static import closure behind the stages' code fingerprints, on a package written here."""

from __future__ import annotations

import sys
import textwrap

import pytest

from roman_sim.core import codehash
from roman_sim.core.codehash import code_closure, code_fingerprint


@pytest.fixture
def pkg(tmp_path, monkeypatch):
    """A package ``cachepkg`` on the path: files -> source."""
    files = {
        "cachepkg/__init__.py": "from cachepkg import registered  # a side effect of importing the package\n",
        "cachepkg/registered.py": "X = 1\n",
        "cachepkg/stage.py": """
            from typing import TYPE_CHECKING
            from cachepkg.util import helper
            from cachepkg.sub import exported
            if TYPE_CHECKING:
                from cachepkg import typing_only
            def run():
                from . import lazy
                return helper(), lazy
            """,
        "cachepkg/util.py": "import json\ndef helper():\n    return 1\n",
        "cachepkg/lazy.py": "from cachepkg import machinery\n",
        "cachepkg/machinery.py": "",
        "cachepkg/typing_only.py": "",
        "cachepkg/sub/__init__.py": "from cachepkg.sub.impl import exported\nfrom cachepkg.sub import other\n",
        "cachepkg/sub/impl.py": "exported = 1\n",
        "cachepkg/sub/other.py": "",
        "cachepkg/unused.py": "",
    }
    for name, text in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    monkeypatch.syspath_prepend(str(tmp_path))
    codehash._package_dir.cache_clear()
    codehash.module_file.cache_clear()
    yield tmp_path
    sys.modules.pop("cachepkg", None)
    codehash._package_dir.cache_clear()
    codehash.module_file.cache_clear()


def test_the_closure_follows_what_a_module_runs(pkg):
    assert code_closure(["cachepkg.stage"]) == [
        "cachepkg.lazy",  # imported inside a function, relatively
        "cachepkg.machinery",
        "cachepkg.stage",
        "cachepkg.sub.impl",  # re-exported by cachepkg.sub: its __init__ and 'other' are not run code
        "cachepkg.util",
    ]  # no TYPE_CHECKING import, no unused module, no package __init__ merely for being a parent
    assert code_closure(["cachepkg.stage"], skip=["cachepkg.lazy"]) == [
        "cachepkg.stage",
        "cachepkg.sub.impl",
        "cachepkg.util",
    ]
    shallow = code_closure(["cachepkg.stage"], shallow=["cachepkg.lazy"])
    assert "cachepkg.lazy" in shallow and "cachepkg.machinery" not in shallow


def test_the_fingerprint_changes_with_the_closure_only(pkg):
    before = code_fingerprint(["cachepkg.stage"])
    assert code_fingerprint(["cachepkg.stage"]) == before
    (pkg / "cachepkg" / "unused.py").write_text("changed = True\n")
    (pkg / "cachepkg" / "sub" / "other.py").write_text("changed = True\n")
    assert code_fingerprint(["cachepkg.stage"]) == before
    (pkg / "cachepkg" / "machinery.py").write_text("changed = True\n")
    assert code_fingerprint(["cachepkg.stage"]) != before
