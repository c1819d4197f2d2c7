"""Corrupt exported worlds name the bad file; ``--out`` onto a file (or a folder for a PNG) is one line."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from roman_sim.core.errors import RomanSimError, WorldError
from roman_sim.world import export_world, load_world


@pytest.fixture(scope="module")
def exported(tiny_world, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("exported") / "tiny"
    export_world(tiny_world, out)
    return out


def _corrupt_json(text: str) -> Callable[[Path], None]:
    return lambda d: (d / "truth.json").write_text(text)


def _edit_truth(fn: Callable[[dict], None]) -> Callable[[Path], None]:
    def edit(d: Path) -> None:
        doc = json.loads((d / "truth.json").read_text())
        fn(doc)
        (d / "truth.json").write_text(json.dumps(doc))

    return edit


def _truncate_mesh(d: Path) -> None:
    mesh = sorted((d / "meshes").glob("*.msh"))[0]
    mesh.write_bytes(mesh.read_bytes()[:100])


@pytest.mark.parametrize(
    ("corrupt", "file", "expect"),
    [
        (_corrupt_json('{"version": 1, "objects": ['), "truth.json", "not valid JSON (line 1: Expecting value)"),
        (_corrupt_json("[1, 2]"), "truth.json", "expected an object, got a list"),
        (_corrupt_json(""), "truth.json", "not valid JSON (line 1: Expecting value)"),
        (_edit_truth(lambda d: d.pop("objects")), "truth.json", "field objects: missing"),
        (_edit_truth(lambda d: d.update(version=99)), "truth.json", "version 99, expected 1"),
        (
            _edit_truth(lambda d: d["objects"][0].update(T_world_obj="x")),
            "truth.json",
            "field objects[0].T_world_obj: expected a list, got a string ('x')",
        ),
        (
            lambda d: (d / "world.xml").write_text("<mujoco><worldbody><geom"),
            "world.xml",
            "MuJoCo cannot load it: XML parse",
        ),
        (
            lambda d: (d / "spec.yaml").write_text("extent_m: [10, 10]\nextent_m: [20, 20]\n"),
            "spec.yaml",
            "duplicate key 'extent_m'",
        ),
        (_truncate_mesh, "world.xml", "unexpected file size in MSH file"),
        (lambda d: (d / "spec.yaml").unlink(), "", "missing spec.yaml (not an exported world folder)"),
    ],
)
def test_corrupt_world_folder_names_the_file(
    exported: Path, tmp_path: Path, corrupt, file: str, expect: str, cli_fails
) -> None:
    d = tmp_path / "w"
    shutil.copytree(exported, d)
    corrupt(d)
    with pytest.raises(RomanSimError) as e:
        load_world(d)
    assert "\n" not in str(e.value)
    assert str(e.value).startswith(str(d / file) if file else str(d)), str(e.value)
    assert expect in str(e.value), str(e.value)
    line = cli_fails("world", "preview", d, "--out", tmp_path / "p", "--width", "32", "--height", "24")
    assert expect in line and not (tmp_path / "p").exists()


def test_a_file_is_not_a_world_folder(tmp_path: Path) -> None:
    f = tmp_path / "world.xml"
    f.write_text("<mujoco/>")
    with pytest.raises(WorldError, match="not a folder"):
        load_world(f)


def test_out_onto_an_existing_file(tmp_path: Path, cli_fails) -> None:
    f = tmp_path / "taken"
    f.write_text("keep me")
    assert cli_fails("world", "generate", "tiny", "--out", f) == (
        f"error: --out {f}: is an existing file, not a folder (choose a folder path)"
    )
    assert cli_fails("world", "preview", "tiny", "--out", f, "--width", "32", "--height", "24") == (
        f"error: --out {f}: is an existing file, not a folder (choose a folder path)"
    )
    line = cli_fails("world", "preview", "tiny", "--out", f / "map.png", "--width", "32", "--height", "24")
    assert line == f"error: --out {f}: is an existing file, not a folder (choose a folder path)"
    (tmp_path / "dir.png").mkdir()
    line = cli_fails("world", "preview", "tiny", "--out", tmp_path / "dir.png", "--width", "32", "--height", "24")
    assert line == f"error: --out {tmp_path / 'dir.png'}: is an existing folder, expected a file path"
    assert f.read_text() == "keep me"


def test_export_into_a_file_path_is_an_error(tiny_world, tmp_path: Path) -> None:
    from roman_sim.core.errors import ConfigError

    f = tmp_path / "f"
    f.write_text("")
    with pytest.raises(ConfigError, match="out_dir .*: is an existing file"):
        export_world(tiny_world, f)
