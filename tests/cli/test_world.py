"""The world CLI: generate, preview, list, ambiguity; bad input gives one line and exit code 1."""

from __future__ import annotations

import mujoco
import pytest
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.cli.listing import LISTINGS


def test_list_through_cli_runner() -> None:
    result = CliRunner().invoke(app, ["list", "worlds"])
    assert result.exit_code == 0
    for name in ("forest", "orchard", "park", "suburb", "offroad", "tiny"):
        assert name in result.output
    assert "worlds" in LISTINGS and "families" in LISTINGS


def test_list_everything(run_cli) -> None:
    code, out, _ = run_cli("list")
    assert code == 0 and "families" in out and "conifer" in out and "worlds" in out


def test_generate_exports_a_loadable_world(run_cli, tmp_path) -> None:
    code, out, err = run_cli("world", "generate", "tiny", "--seed", "2", "--out", str(tmp_path / "w"))
    assert code == 0, err
    assert "total" in out
    assert mujoco.MjModel.from_xml_path(str(tmp_path / "w" / "world.xml")).ngeom > 1


def test_preview_from_preset_and_from_folder(run_cli, tmp_path) -> None:
    code, _, err = run_cli(
        "world", "preview", "tiny", "--out", str(tmp_path / "p.png"), "--width", "64", "--height", "48"
    )
    assert code == 0, err
    assert (tmp_path / "p.png").stat().st_size > 0 and (tmp_path / "p_view.png").stat().st_size > 0
    assert (tmp_path / "p.pdf").read_bytes().startswith(b"%PDF")  # the map's vector copy (the view is a photo)
    assert not (tmp_path / "p_view.pdf").exists()
    run_cli("world", "generate", "tiny", "--out", str(tmp_path / "w"))
    code, _, err = run_cli(
        "world", "preview", str(tmp_path / "w"), "--out", str(tmp_path / "prev"), "--width", "64", "--height", "48"
    )
    assert code == 0, err
    assert (tmp_path / "prev" / "topdown.png").is_file() and (tmp_path / "prev" / "view.png").is_file()
    assert (tmp_path / "prev" / "topdown.pdf").read_bytes().startswith(b"%PDF")


def test_ambiguity_command(run_cli) -> None:
    code, out, err = run_cli("world", "ambiguity", "tiny", "--places", "5")
    assert code == 0 and "ambiguity index" in out, err


@pytest.mark.parametrize(
    ("args", "expect"),
    [
        (["world", "generate", "jungle"], "unknown world preset 'jungle' (valid: forest"),
        (["world", "generate", "BAD_YAML"], "malformed YAML"),
        (["world", "generate", "UNKNOWN_KEY"], "colour: unknown key"),
        (
            ["world", "generate", "tiny", "--set", "families.0.density=-2"],
            "families.0.density: Input should be greater than or equal to 0",
        ),
        (
            ["world", "generate", "tiny", "--set", "families.0.density=1500", "--set", "max_objects=50"],
            "more than max_objects=50",
        ),
        (["world", "generate", "tiny", "--seed", "-1"], "seed must be a non-negative integer"),
        (
            [
                "world",
                "generate",
                "tiny",
                "--set",
                "extent_m=[10,10]",
                "--set",
                "families=[{name: house, density: 300}]",
            ],
            "no object fits the extent",
        ),
        (
            [
                "world",
                "generate",
                "tiny",
                "--set",
                "appearance.textures=true",
                "--set",
                "appearance.texture_memory_mb=0.01",
            ],
            "appearance.texture_memory_mb: ",
        ),
        (
            ["world", "generate", "tiny", "--set", "appearance.texture_scope=world"],
            "appearance.texture_scope: Input should be 'instance' or 'surface'",
        ),
        (["world", "preview", "MISSING_DIR_FILE"], "missing truth.json"),
        (["list", "robots"], "unknown 'robots' (valid:"),
        (["world", "preview", "tiny", "--width", "4000"], "width must be in [16, 1280]"),
    ],
)
def test_bad_input_one_line_exit_1(run_cli, tmp_path, args: list[str], expect: str) -> None:
    (tmp_path / "bad.yaml").write_text("families: [\n")
    (tmp_path / "unknown.yaml").write_text("families: [{name: bush, density: 1}]\ncolour: red\n")
    (tmp_path / "half").mkdir()
    (tmp_path / "half" / "world.xml").write_text("<mujoco/>")
    (tmp_path / "half" / "spec.yaml").write_text("families: [{name: bush, density: 1}]\n")
    subst = {
        "BAD_YAML": str(tmp_path / "bad.yaml"),
        "UNKNOWN_KEY": str(tmp_path / "unknown.yaml"),
        "MISSING_DIR_FILE": str(tmp_path / "half"),
    }
    args = [subst.get(a, a) for a in args]
    if args[1] in ("generate", "preview"):
        args += ["--out", str(tmp_path / "out")]
    code, out, err = run_cli(*args)
    assert code == 1
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and expect in lines[0], err


def test_same_bytes_in_a_fresh_process(tmp_path) -> None:
    """Determinism does not depend on the process (hash seeds, import order)."""
    import subprocess
    import sys

    from roman_sim.world import export_world, generate, load_world_spec

    export_world(generate(load_world_spec("tiny"), 4), tmp_path / "here")
    cmd = [
        sys.executable,
        "-c",
        "from roman_sim.cli import app; app()",
        "world",
        "generate",
        "tiny",
        "--seed",
        "4",
        "--out",
        str(tmp_path / "there"),
    ]
    subprocess.run(cmd, check=True, capture_output=True, env={"PYTHONHASHSEED": "123", "PATH": ""})
    for name in ("world.xml", "truth.json", "meshes/ground.png"):
        assert (tmp_path / "here" / name).read_bytes() == (tmp_path / "there" / name).read_bytes()
