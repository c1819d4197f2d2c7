"""TUM RGB-D export: layout and counts, read back against the simulator's own frames, side files.

Depth tolerance: the PNGs hold ``round(depth * 5000)``, so a reading comes back within half
a unit, 0.5 / 5000 m = 0.1 mm, plus float32 rounding of the metre value (1.2e-7 at 1 m);
readings deeper than 65535 / 5000 = 13.107 m are stored as 0 (invalid). Poses are written
with 9 decimals: back to 1e-6 with a wide margin.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.tum import read_tum
from roman_sim.interop.associate import associate, read_list
from roman_sim.interop.images import depth_to_units, read_png, units_to_depth
from roman_sim.interop.objects import read_object_table
from roman_sim.interop.tum_camera import read_camera_file
from roman_sim.interop.tum_reader import read_tum_sequence

from .conftest import FRAMES

DEPTH_TOL_M = 0.5 / 5000 + 2e-6  # half a PNG unit + float32 rounding up to ~15 m


def _tree_digest(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def test_layout_and_counts(tum_export: Path) -> None:
    for robot, n in FRAMES.items():
        d = tum_export / robot
        for name in ("rgb", "depth", "masks"):
            stamps, files = read_list(d / f"{name}.txt")
            assert len(stamps) == n and all((d / f).is_file() for f in files)
            assert len(list((d / name).glob("*.png"))) == n
        for name in ("groundtruth.txt", "odometry.txt", "groundtruth_body.txt", "odometry_body.txt"):
            traj = read_tum(d / name)
            assert len(traj) == n and traj.T.shape == (n, 4, 4)
        assert len((d / "associations.txt").read_text().splitlines()) == n
    manifest = json.loads((tum_export / "export.json").read_text())
    assert manifest["sequence_format"] == "tum" and {r: v["frames"] for r, v in manifest["robots"].items()} == FRAMES


def test_images_and_poses_read_back(tum_export: Path, direct_frames: dict) -> None:
    for robot, frames in direct_frames.items():
        seq = read_tum_sequence(tum_export / robot, robot=robot)
        back = list(seq.frames())
        assert len(back) == len(frames) == FRAMES[robot] and seq.has_masks
        for f, g in zip(frames, back):
            assert g.intrinsics == f.intrinsics and abs(g.t - f.t) < 1e-9
            np.testing.assert_array_equal(g.rgb, f.rgb)
            np.testing.assert_array_equal(g.depth == 0, f.depth == 0)
            assert np.max(np.abs(g.depth.astype(np.float64) - f.depth)) <= DEPTH_TOL_M
            np.testing.assert_array_equal(g.truth.object_ids, f.truth.object_ids)
            np.testing.assert_allclose(g.T_odom_body, f.T_odom_body, atol=1e-6)
            np.testing.assert_allclose(g.truth.T_world_body, f.truth.T_world_body, atol=1e-6)
            np.testing.assert_allclose(g.T_body_cam, f.T_body_cam, atol=1e-12)


def test_groundtruth_is_the_camera_pose(tum_export: Path, direct_frames: dict) -> None:
    f = direct_frames["a"]
    T_cam = read_tum(tum_export / "a" / "groundtruth.txt").T
    T_body = read_tum(tum_export / "a" / "groundtruth_body.txt").T
    T_odom_cam = read_tum(tum_export / "a" / "odometry.txt").T
    np.testing.assert_allclose(T_cam, [x.truth.T_world_body @ x.T_body_cam for x in f], atol=1e-6)
    np.testing.assert_allclose(T_body, [x.truth.T_world_body for x in f], atol=1e-6)
    np.testing.assert_allclose(T_odom_cam, [x.T_odom_body @ x.T_body_cam for x in f], atol=1e-6)


def test_lists_associate_one_to_one_like_the_tum_tools(tum_export: Path) -> None:
    t_rgb, rgb = read_list(tum_export / "a" / "rgb.txt")
    t_d, depth = read_list(tum_export / "a" / "depth.txt")
    i, j = associate(t_rgb, t_d, 0.02)
    np.testing.assert_array_equal(i, np.arange(FRAMES["a"]))
    np.testing.assert_array_equal(j, np.arange(FRAMES["a"]))
    assert [Path(r).stem for r in rgb] == [Path(d).stem for d in depth]


def test_camera_files(tum_export: Path, direct_frames: dict) -> None:
    intr = direct_frames["a"][0].intrinsics
    cam = read_camera_file(tum_export / "a")
    assert cam is not None and cam.depth_scale == 5000.0 and cam.intrinsics(160, 120) == intr
    (tum_export / "a" / "camera.yaml").rename(tum_export / "a" / "camera.yaml.bak")
    try:
        txt = read_camera_file(tum_export / "a")
        assert txt is not None and (txt.width, txt.height) == (160, 120)
        k = txt.intrinsics(160, 120)
        assert abs(k.fx - intr.fx) < 1e-8 and abs(k.fy - intr.fy) < 1e-8 and (k.cx, k.cy) == (intr.cx, intr.cy)
    finally:
        (tum_export / "a" / "camera.yaml.bak").rename(tum_export / "a" / "camera.yaml")


def test_masks_and_object_table(tum_export: Path, direct_frames: dict, tiny_scenario) -> None:
    from roman_sim.world import generate

    truth = generate(tiny_scenario.world.spec(), tiny_scenario.seed).truth
    rows = read_object_table(tum_export)
    assert [r.id for r in rows] == [o.id for o in truth.objects]
    for r, o in zip(rows, truth.objects):
        assert r.family == o.family and r.mask_value == o.id + 1
        np.testing.assert_allclose(r.box.center, o.obb_T_world[:3, 3], atol=1e-9)
        np.testing.assert_allclose(r.box.extents, o.obb_extents, atol=1e-9)
    csv_lines = (tum_export / "objects.csv").read_text().splitlines()
    assert len(csv_lines) == len(truth.objects) + 1 and csv_lines[0].startswith("id,mask_value,family")
    for robot, frames in direct_frames.items():
        _, files = read_list(tum_export / robot / "masks.txt")
        for f, name in zip(frames, files):
            mask = read_png(tum_export / robot / name)
            assert mask.dtype == np.uint16
            np.testing.assert_array_equal(mask.astype(np.int32) - 1, f.truth.object_ids)


def test_depth_quantisation_bounds() -> None:
    d = np.array([[0.0, 1e-5, 1.23456, 13.107, 13.108, 20.0, np.nan, -1.0]], dtype=np.float32)
    units, dropped = depth_to_units(d)
    assert units.dtype == np.uint16 and dropped == 2
    np.testing.assert_array_equal(units[0], [0, 0, 6173, 65535, 0, 0, 0, 0])
    back = units_to_depth(units)
    assert abs(float(back[0, 2]) - 1.23456) <= 0.5 / 5000 and back[0, 4] == 0 and back[0, 1] == 0


def test_same_seed_same_bytes(tum_export: Path, tiny_scenario, tmp_path: Path) -> None:
    from roman_sim.interop import export_scenario

    export_scenario(tiny_scenario, "tum", tmp_path / "again")
    assert _tree_digest(tmp_path / "again") == _tree_digest(tum_export)


def test_existing_folder_is_not_overwritten(tum_export: Path, tiny_scenario) -> None:
    from roman_sim.core.errors import ConfigError
    from roman_sim.interop import export_scenario

    with pytest.raises(ConfigError, match="--overwrite"):
        export_scenario(tiny_scenario, "tum", tum_export, robots=["a"])
