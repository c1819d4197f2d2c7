"""The static import closure behind the stages' code fingerprints, on a package written here."""

from __future__ import annotations

import platform
import sys
import textwrap
from importlib.metadata import version

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


def test_a_helper_module_beside_the_package_is_followed_and_libraries_are_versioned(pkg, monkeypatch):
    """A top-level module outside the installed libraries is code the package runs; numpy is a library."""
    (pkg / "cachepkg" / "machinery.py").write_text("import besidehelper\nimport numpy\n")
    (pkg / "besidehelper.py").write_text("import scipy\n")
    codehash.is_installed.cache_clear()
    closure = code_closure(["cachepkg.stage"])
    assert "besidehelper" in closure and "numpy" not in closure and "json" not in closure
    libraries = codehash.code_libraries(["cachepkg.stage"])
    assert libraries["numpy"] == version("numpy") and libraries["scipy"] == version("scipy")
    assert libraries["python"] == platform.python_version() and "json" not in libraries
    before = code_fingerprint(["cachepkg.stage"])
    (pkg / "besidehelper.py").write_text("import scipy\n# edited\n")
    assert code_fingerprint(["cachepkg.stage"]) != before
    edited = code_fingerprint(["cachepkg.stage"])
    real = codehash.library_versions
    monkeypatch.setattr(
        codehash, "library_versions", lambda tops: {**real(tops), "numpy": "0.0.1"} if "numpy" in tops else real(tops)
    )
    assert code_fingerprint(["cachepkg.stage"]) != edited  # another numpy: another fingerprint
    sys.modules.pop("besidehelper", None)
    codehash.is_installed.cache_clear()
