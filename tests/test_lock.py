"""The lock (``constraints.txt``): it pins everything the package and its tests import, CI installs with it."""

from __future__ import annotations

import ast
import logging
import re
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from readme_commands import FIRST, TEST, marked_command, no_deps_installs

from roman_sim.studies.lockfile import LOCK_FILE, lock_changes, locked_versions, normalize, warn_unlocked

ROOT = Path(__file__).resolve().parent.parent
LOCK = ROOT / LOCK_FILE
#: Modules the tests write at run time (user plug-ins), and the standard library's typing-only stubs.
NOT_DISTRIBUTIONS = {"roman_user_plugins_t", "w11_uploaded_plugin", "_typeshed"}


def _imports(folder: Path) -> dict[str, str]:
    """Top-level module -> one file importing it, over every import of every file (lazy ones included)."""
    out: dict[str, str] = {}
    for path in sorted(folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                out.setdefault(name.split(".")[0], str(path.relative_to(ROOT)))
    return out


def _third_party() -> dict[str, str]:
    local = {p.stem for p in (ROOT / "tests").rglob("*.py")}  # helper modules beside the tests
    found = {**_imports(ROOT / "tests"), **_imports(ROOT / "roman_sim")}
    skip = set(sys.stdlib_module_names) | local | NOT_DISTRIBUTIONS | {"roman_sim", "__future__", "tests"}
    return {m: f for m, f in found.items() if m not in skip}


def _ci_pins() -> dict[str, str]:
    """Exact pins the README's test command (CI runs it) installs beside the lock (``pip install --no-deps``)."""
    return {normalize(n): v for n, v in (r.split("==") for r in no_deps_installs(marked_command(TEST)))}


def test_the_lock_pins_every_third_party_import_of_the_package_and_its_tests():
    assert "robotdatapy" in _ci_pins()  # installed without its dependencies, pinned where it is installed
    pins = {**locked_versions(LOCK), **_ci_pins()}
    providers = metadata.packages_distributions()
    modules = _third_party()
    assert {"numpy", "cv2", "mujoco", "torch", "pytest", "distributed"} <= set(modules)  # the walk finds imports
    unknown = {m: f for m, f in modules.items() if m not in providers}
    assert not unknown, f"imported, but no installed distribution provides them: {unknown}"
    unpinned = {m: providers[m] for m in modules if not {normalize(d) for d in providers[m]} & set(pins)}
    assert not unpinned, f"{LOCK_FILE} pins no distribution of {unpinned}: run tools/update_lock.sh"


def test_the_lock_pins_every_declared_dependency_with_every_extra():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    declared = project["dependencies"] + [r for extra in project["optional-dependencies"].values() for r in extra]
    pins = locked_versions(LOCK)
    for line in declared:
        req = Requirement(line)
        assert normalize(req.name) in pins, f"{req.name} is not in {LOCK_FILE}"
        assert req.specifier.contains(pins[normalize(req.name)], prereleases=True), (line, pins[normalize(req.name)])


def test_the_lock_is_a_constraints_file_of_exact_pins():
    """pip refuses extras, URLs and editable lines in a constraints file; every pin is exact."""
    lines = [ln.split("#", 1)[0].strip() for ln in LOCK.read_text(encoding="utf-8").splitlines()]
    entries = [ln for ln in lines if ln]
    assert len(entries) > 100
    bad = [ln for ln in entries if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*==[A-Za-z0-9.+!]+", ln)]
    assert not bad, bad
    assert len({normalize(e.split("==")[0]) for e in entries}) == len(entries)
    assert locked_versions(LOCK)["torch"].startswith("2.13.0")  # the CPU build the test extra pins


def test_ci_and_the_readme_install_with_the_lock():
    assert marked_command(TEST).startswith(f'pip install -e ".[test]" -c {LOCK_FILE} && ')
    assert marked_command(FIRST) == "pip install -e . && roman-sim demo"  # users' first install stays open
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    installs = [ln for ln in ci.splitlines() if "pip install" in ln and "-e" in ln]
    assert installs and all(f"-c {LOCK_FILE}" in ln for ln in installs), installs


def _lock(tmp_path: Path, pins: dict[str, str]) -> Path:
    path = tmp_path / LOCK_FILE
    text = "# a lock\n" + "".join(f"{n}=={v}\n    # via\n    #   roman_sim (pyproject.toml)\n" for n, v in pins.items())
    path.write_text(text)
    return path


def test_lock_changes_names_each_installed_version_that_differs(tmp_path):
    numpy, pyyaml = metadata.version("numpy"), metadata.version("PyYAML")
    path = _lock(tmp_path, {"numpy": "1.0.0", "PyYAML": pyyaml, "no-such-distribution-x": "1.0"})
    assert locked_versions(path) == {"numpy": "1.0.0", "pyyaml": pyyaml, "no-such-distribution-x": "1.0"}
    assert lock_changes(path) == [f"numpy 1.0.0 -> {numpy}"]
    assert lock_changes(_lock(tmp_path, {"numpy": numpy})) == []


def test_reproduce_warns_once_naming_the_versions_that_differ(tmp_path, caplog):
    numpy = metadata.version("numpy")
    _lock(tmp_path, {"numpy": "1.0.0", "PyYAML": metadata.version("PyYAML")})
    with caplog.at_level(logging.WARNING, logger="roman_sim.studies.lockfile"):
        assert warn_unlocked(tmp_path) == [f"numpy 1.0.0 -> {numpy}"]
    assert [r.getMessage() for r in caplog.records] == [
        f"this environment differs from {tmp_path / LOCK_FILE}, the versions the reference results were made with "
        f"(numpy 1.0.0 -> {numpy}): the results may differ from the committed ones (install the locked versions: "
        f"pip install -e . -c {LOCK_FILE})"
    ]
    caplog.clear()
    assert warn_unlocked(tmp_path / "elsewhere") == []  # no lock: nothing to compare with
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


@pytest.mark.parametrize("name", ["ruamel.yaml", "Ruamel_YAML", "ruamel-yaml"])
def test_names_compare_as_pip_compares_them(name):
    assert normalize(name) == "ruamel-yaml"
