"""The built wheel runs on its own: scenarios, presets and examples are package data.

The wheel is built from the checkout and installed into a fresh virtual environment that
sees the already-installed dependencies (through a ``.pth`` line, so the checkout's own
editable install is not visible); ``roman-sim run smoke`` then runs from an empty folder.
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel_env(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    base = tmp_path_factory.mktemp("wheel")
    dist = base / "dist"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(dist), str(ROOT)],
        check=True,
        timeout=300,
        cwd=base,
    )
    (wheel,) = dist.glob("roman_sim-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for needed in (
        "roman_sim/scenarios/smoke.yaml",
        "roman_sim/scenarios/sweeps/ambiguity_sweep.yaml",
        "roman_sim/world/presets/tiny.yaml",
        "roman_sim/examples/mutual_nn_aligner.py",
        "roman_sim/py.typed",
    ):
        assert needed in names, f"{needed} missing from the wheel"
    venv = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    site = Path(
        subprocess.run(
            [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    )
    # dependencies from this interpreter's environment (a plain path: its .pth files, the
    # editable install of the checkout among them, are not processed)
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site), str(wheel)],
        check=True,
        timeout=300,
    )
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    return py, env


def test_wheel_holds_the_package_data_and_imports_from_itself(wheel_env, tmp_path):
    py, env = wheel_env

    def stdout(*args: str) -> str:
        return subprocess.run(
            [str(py), *args], cwd=tmp_path, env=env, capture_output=True, text=True, check=True
        ).stdout

    out = stdout("-c", "import roman_sim, sys; print(roman_sim.__file__)")
    assert str(ROOT) not in out and "site-packages" in out
    listed = stdout("-m", "roman_sim.cli", "list", "scenarios")
    assert "smoke" in listed and "demo" in listed


@pytest.mark.slow
def test_installed_wheel_runs_smoke_from_an_empty_folder(wheel_env, tmp_path):
    py, env = wheel_env
    res = subprocess.run(
        [
            str(py),
            "-m",
            "roman_sim.cli",
            "run",
            "smoke",
            "--out",
            "out",
            "--aligner",
            "roman_sim.examples.mutual_nn_aligner:MutualNNAligner",
            # both robots stop after 12 m: what is checked is that the wheel's data and plug-in run
            "--set",
            "robots.0.max_length_m=12",
            "--set",
            "robots.1.max_length_m=12",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    assert (tmp_path / "out" / "report.md").is_file()
    assert "MutualNNAligner" in (tmp_path / "out" / "report.md").read_text()
