"""``roman-sim export``: writes the sequences; bad input gives one line and exit code 1."""

from __future__ import annotations

import json
from pathlib import Path

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
    ]
    for args, message in cases:
        code, _, err = run_cli("export", sc, "--out", str(tmp_path / "bad"), *args)
        assert code == 1 and message in err and "Traceback" not in err, (args, err)
        assert len(err.strip().splitlines()) == 1, err
    code, _, err = run_cli("export", "no_such_scenario", "--format", "tum", "--out", str(tmp_path / "x"))
    assert code == 1 and "no such file or bundled scenario" in err
