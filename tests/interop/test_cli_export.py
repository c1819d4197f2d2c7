"""``roman-sim export``: writes the sequences (``roman_sim.interop``); bad input gives one line and exit code 1."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from .conftest import TINY


def _scenario_file(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY))
    return path


def test_export_tum_one_robot(run_cli, tmp_path: Path) -> None:
    code, out, err = run_cli(
        "export",
        str(_scenario_file(tmp_path)),
        "--format",
        "tum",
        "--out",
        str(tmp_path / "o"),
        "--robots",
        "b",
        "--set",
        "robots.1.max_duration_s=0.5",
    )
    assert code == 0, err
    assert "exported as tum" in out
    manifest = json.loads((tmp_path / "o" / "export.json").read_text())
    assert manifest["robots"] == {"b": {"frames": 4, "depth_dropped_too_deep": 0}}
    assert not (tmp_path / "o" / "a").exists()
    assert len((tmp_path / "o" / "b" / "rgb.txt").read_text().splitlines()) == 3 + 4


def test_bad_input_is_one_line(run_cli, tmp_path: Path) -> None:
    sc = str(_scenario_file(tmp_path))
    cases = [
        (["--format", "ply"], "unknown export format 'ply'"),
        (["--format", "tum", "--robots", "a,zz"], "no simulated robot zz"),
        (["--format", "rosbag2", "--storage", "tape"], "storage: unknown 'tape'"),
        (["--format", "tum", "--depth-scale", "0"], "--depth-scale"),
        (["--format", "tum", "--set", "robots.0.speed_mps=-1"], "robots.0.speed_mps"),
        (["--format", "euroc", "--set", "robots.0.imu.rate_hz=200"], "imu.rate_hz: 200 Hz is not a whole multiple"),
        (["--format", "euroc", "--set", "robots.0.stereo.baseline_m=0"], "robots.0.stereo.baseline_m"),
        (["--format", "rosbag2", "--set", "robots.1.stereo.baseline_m=-0.1"], "robots.1.stereo.baseline_m"),
        (["--format", "tum", "--set", "robots.0.camera.vfov_deg=10"], "robots.0.camera: vfov_deg (10) with hfov_deg"),
    ]
    for i, (args, message) in enumerate(cases):
        code, _, err = run_cli("export", sc, "--out", str(tmp_path / f"bad{i}"), *args)
        assert code == 1 and message in err and "Traceback" not in err, (args, err)
        assert len(err.strip().splitlines()) == 1, err
        if "--set" in args:  # a bad scenario value stops before anything is written
            assert not (tmp_path / f"bad{i}").exists(), args
    code, _, err = run_cli("export", "no_such_scenario", "--format", "tum", "--out", str(tmp_path / "x"))
    assert code == 1 and "no such file or bundled scenario" in err


def test_a_bundled_scenario_exports_square_pixels_and_explicit_vfov_warns(
    run_cli, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """``roman-sim export smoke`` writes fx == fy (the default camera) without a pixel warning, and
    says a TUM export drops an IMU; an explicit ``vfov_deg`` writes its fy and is named."""
    base = ["--robots", "b", "--set", "robots.1.max_duration_s=0.2"]
    code, _, err = run_cli(
        "export", "smoke", "--format", "tum", "--out", str(tmp_path / "t"), *base, "--set", "robots.1.imu.preset=euroc"
    )
    assert code == 0, err
    assert "not square" not in caplog.text
    assert "robot b: the tum format has no IMU or second camera" in caplog.text
    line = (tmp_path / "t" / "b" / "camera.txt").read_text().splitlines()[1].split()
    fx, fy = float(line[0]), float(line[1])
    assert fx == fy == pytest.approx(80.0 / math.tan(math.radians(43.5)), abs=1e-8)  # 160 x 120, 87 deg
    cam = yaml.safe_load((tmp_path / "t" / "b" / "camera.yaml").read_text())
    assert cam["fx"] == cam["fy"] and (cam["width"], cam["height"]) == (160, 120)
    caplog.clear()
    vfov = ["--set", "robots.1.camera.vfov_deg=58"]
    code, _, err = run_cli("export", "smoke", "--format", "euroc", "--out", str(tmp_path / "e"), *base, *vfov)
    assert code == 0, err
    assert "robot b: the camera's pixels are not square (fx 84.302, fy 108.243)" in caplog.text
    assert "no IMU" not in caplog.text, caplog.text
    sensor = yaml.safe_load((tmp_path / "e" / "b" / "mav0" / "cam0" / "sensor.yaml").read_text())
    assert sensor["intrinsics"][:2] == pytest.approx([fx, 60.0 / math.tan(math.radians(29.0))], abs=1e-9)
    manifest = json.loads((tmp_path / "e" / "export.json").read_text())
    assert manifest["time_epoch_ns"] == 1_700_000_000_000_000_000
