"""ROMAN-ready export, loaded with robotdatapy the way the reference ROMAN's data configuration loads it.

The reference implementation (``roman.params.data_params.DataParams``) reads ``data.yaml``:
for each run it sets ``$ROBOT``, merges the run's own section over the top level, gives the
image streams ``time_tol = dt / 2`` and ``type: bag``, expands the variables and calls
``ImgData.from_dict`` (camera parameters from the ``camera_info`` topic), loads the poses
with ``PoseData.from_dict`` (``interp: True``) and ``T_camera_flu`` from a matrix, and its
demo reads ``gt_pose.yaml`` with the ``PoseData`` reader its ``type`` names. Paths are
relative to the export folder, the working directory the reference runs in. The helpers
below do the same calls; robotdatapy is the real client. Stamps count from the export
epoch: ``EPOCH_S`` + the frame time.
"""

from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from rosbags.rosbag2 import Reader

from roman_sim.core.geometry import inv_T

from .conftest import EPOCH_NS, FRAMES

rdp = pytest.importorskip("robotdatapy.data")

EPOCH_S = EPOCH_NS / 1e9
#: Float seconds near the epoch (1.7e9 s) resolve 2.4e-7 s.
STAMP_TOL_S = 5e-7


@pytest.fixture(scope="module")
def roman_export(tiny_scenario: Any, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from roman_sim.interop import export_scenario

    out = tmp_path_factory.mktemp("roman") / "export"
    export_scenario(tiny_scenario, "roman", out, storage="sqlite3")
    return out


def _merged(d: dict, over: dict) -> dict:
    out = copy.deepcopy(d)
    for k, v in over.items():
        out[k] = _merged(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _expand(d: dict) -> dict:
    return {k: os.path.expandvars(v) if isinstance(v, str) else v for k, v in d.items()}


def _load(params: Path, robot: str, monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """Images, depth, camera poses, T_camera_flu and truth of one run, as the reference loads them
    when it runs in the export folder (``params``'s parent)."""
    monkeypatch.chdir(params.parent)
    data = yaml.safe_load((params / "data.yaml").read_text(encoding="utf-8"))
    monkeypatch.setenv(data["run_env"], robot)
    run = _merged(data, data[robot]) if robot in data else data
    out: dict[str, Any] = {"dt": run["dt"], "runs": data["runs"]}
    for key in ("img_data", "depth_data"):
        p = _expand({**run[key], "time_tol": run["dt"] / 2.0, "time_range": None})
        out[key] = rdp.ImgData.from_dict(p)
    pose = {k: v for k, v in run["pose_data"].items() if k not in ("T_camera_flu", "T_odombase_camera")}
    out["pose"] = rdp.PoseData.from_dict(_expand({**pose, "T_postmultiply": None, "interp": True}))
    tf = run["pose_data"]["T_camera_flu"]
    assert tf["input_type"] == "matrix"
    out["T_camera_flu"] = np.array(tf["matrix"], dtype=np.float64).reshape(4, 4)
    gt = yaml.safe_load((params / "gt_pose.yaml").read_text(encoding="utf-8"))
    reader = {"bag": rdp.PoseData.from_bag, "csv": rdp.PoseData.from_csv}[gt["type"]]
    out["gt"] = reader(**{k: v for k, v in gt.items() if k != "type"})
    return out


@pytest.mark.parametrize("robot", ["a", "b"])
def test_reference_data_loading(
    roman_export: Path, direct_frames: dict, robot: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    frames = direct_frames[robot]
    d = _load(roman_export / "roman_params", robot, monkeypatch)
    assert d["runs"] == ["a", "b"] and d["dt"] == 1 / 6  # 1 / rate_hz as configured, not a median of stamps
    img, depth = d["img_data"], d["depth_data"]
    t = np.array([f.t for f in frames])
    for stream in (img, depth):
        assert len(stream.times) == FRAMES[robot]
        np.testing.assert_allclose(np.asarray(stream.times) - EPOCH_S, t, atol=STAMP_TOL_S)
    k = frames[0].intrinsics
    K = np.array([[k.fx, 0, k.cx], [0, k.fy, k.cy], [0, 0, 1]])
    for stream in (img, depth):
        cp = stream.camera_params
        np.testing.assert_allclose(cp.K, K, atol=1e-9)
        assert (cp.width, cp.height) == (k.width, k.height)
    T_cam_flu = d["T_camera_flu"]
    np.testing.assert_allclose(T_cam_flu, inv_T(frames[0].T_body_cam), atol=1e-9)
    for f in frames[:: max(1, len(frames) // 4)]:
        stamp = EPOCH_S + f.t
        bgr = img.img(stamp)
        np.testing.assert_array_equal(bgr, np.asarray(f.rgb)[..., ::-1])  # OpenCV order
        mm = depth.img(stamp)
        assert mm.dtype == np.uint16
        ok = np.isfinite(f.depth) & (f.depth > 0)
        np.testing.assert_array_equal(mm[~ok], 0)
        assert np.abs(mm[ok] / 1000.0 - f.depth[ok]).max() <= 0.0005 + 1e-6
        T_odom_cam = d["pose"].T_WB(stamp)
        np.testing.assert_allclose(T_odom_cam, f.T_odom_body @ f.T_body_cam, atol=1e-6)
        # what the reference mapper keeps as the body trajectory: pose @ T_camera_flu
        np.testing.assert_allclose(T_odom_cam @ T_cam_flu, f.T_odom_body, atol=1e-6)
        np.testing.assert_allclose(d["gt"].T_WB(stamp), f.truth.T_world_body, atol=1e-6)


def _inside(world: np.ndarray, box: dict, margin: np.ndarray) -> np.ndarray:
    local = (world - np.asarray(box["center"])) @ np.asarray(box["R"])
    return np.all(np.abs(local) <= np.asarray(box["extents"])[None, :] / 2 + margin[:, None], axis=1)


def test_back_projected_object_lands_in_its_box(
    roman_export: Path, direct_frames: dict, tiny_scenario: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Depth at the reference front end's default scale (1000 per metre) puts an object's pixels in its true box.

    The margin is three standard deviations of the simulated depth noise at each point's
    depth; the same points read as metres (a scale of 1) land outside every box.
    """
    import json

    objects = {o["id"]: o for o in json.loads((roman_export / "objects.json").read_text())["objects"]}
    fastsam = yaml.safe_load((roman_export / "roman_params" / "fastsam.yaml").read_text(encoding="utf-8"))
    assert fastsam["depth_scale"] == 1000.0
    noise = tiny_scenario.robots[0].camera.depth_noise
    d = _load(roman_export / "roman_params", "a", monkeypatch)
    K = d["img_data"].camera_params.K
    checked, wrong_scale = 0, []
    for f in direct_frames["a"]:
        ids = np.asarray(f.truth.object_ids)
        raw = d["depth_data"].img(EPOCH_S + f.t).astype(np.float64)
        T_world_cam = d["gt"].T_WB(EPOCH_S + f.t) @ inv_T(d["T_camera_flu"])
        for oid in np.unique(ids[ids >= 0]):
            v, u = np.nonzero((ids == oid) & (raw > 0))
            if len(u) < 50:
                continue
            box = objects[int(oid)]["box"]
            for scale in (fastsam["depth_scale"], 1.0):
                z = raw[v, u] / scale
                pts = np.column_stack([(u - K[0, 2]) * z / K[0, 0], (v - K[1, 2]) * z / K[1, 1], z, np.ones_like(z)])
                world = (T_world_cam @ pts.T).T[:, :3]
                margin = 0.02 + 3 * noise.std_at_ref_m * (np.minimum(z, 100.0) / noise.ref_range_m) ** 2
                inside = _inside(world, box, margin if scale != 1.0 else np.full(len(z), 0.02))
                if scale == 1.0:
                    wrong_scale.append(inside.mean())
                else:
                    assert inside.mean() >= 0.97, (f.t, int(oid), inside.mean())
            checked += 1
    assert checked >= 5
    assert max(wrong_scale) == 0.0


def test_bag_for_humble_and_evo(roman_export: Path, direct_frames: dict) -> None:
    """Metadata version 8 (QoS as Humble's YAML string); evo reads the truth and odometry topics;
    each robot's bag has its own truth topic, so bags played together do not mix."""
    from evo.core import sync
    from evo.tools import file_interface

    bag = roman_export / "a" / "bag"
    meta = yaml.safe_load((bag / "metadata.yaml").read_text(encoding="utf-8"))["rosbag2_bagfile_information"]
    assert meta["version"] == 8 and meta["storage_identifier"] == "sqlite3"
    assert all(isinstance(t["topic_metadata"]["offered_qos_profiles"], str) for t in meta["topics_with_message_count"])
    frames = direct_frames["a"]
    with Reader(bag) as reader:
        gt = file_interface.read_bag_trajectory(reader, "/a/groundtruth")
        odom = file_interface.read_bag_trajectory(reader, "/a/odom")
    for robot in FRAMES:
        with Reader(roman_export / robot / "bag") as reader:
            truth_topics = sorted(c.topic for c in reader.connections if c.topic.endswith("groundtruth"))
        assert truth_topics == [f"/{robot}/groundtruth"]
    assert gt.num_poses == odom.num_poses == FRAMES["a"]
    np.testing.assert_allclose(gt.timestamps - EPOCH_S, [f.t for f in frames], atol=STAMP_TOL_S)
    np.testing.assert_allclose(gt.poses_se3, [f.truth.T_world_body for f in frames], atol=1e-6)
    np.testing.assert_allclose(odom.poses_se3, [f.T_odom_body for f in frames], atol=1e-6)
    gt, odom = sync.associate_trajectories(gt, odom)
    assert gt.num_poses == FRAMES["a"]


def test_parameter_folders(roman_export: Path, tiny_scenario: Any) -> None:
    for folder, device in (("roman_params", "cuda"), ("roman_params_cpu", "cpu")):
        p = roman_export / folder
        assert sorted(x.name for x in p.iterdir()) == [
            "data.yaml",
            "fastsam.yaml",
            "gt_pose.yaml",
            "mapper.yaml",
            "offline_rpgo.yaml",
            "submap_align.yaml",
        ]
        fs = yaml.safe_load((p / "fastsam.yaml").read_text(encoding="utf-8"))
        assert fs["device"] == device and fs["max_depth"] == tiny_scenario.robots[0].camera.max_depth_m
        sa = yaml.safe_load((p / "submap_align.yaml").read_text(encoding="utf-8"))
        assert sa["submap_radius"] == tiny_scenario.submaps.submap_radius
        assert sa["method"] == ("roman" if device == "cuda" else "roman_no_semantics")


def test_parameters_are_relative_and_dt_as_configured(roman_export: Path, direct_frames: dict, tmp_path: Path) -> None:
    """No absolute path in a parameter file: a moved export still loads; ``dt`` is written as 1 / rate_hz."""
    import shutil

    for folder in ("roman_params", "roman_params_cpu"):
        for f in (roman_export / folder).iterdir():
            text = f.read_text(encoding="utf-8")
            assert str(roman_export) not in text and "path: /" not in text, f
    data = (roman_export / "roman_params" / "data.yaml").read_text(encoding="utf-8")
    assert data.startswith("dt: 0.16666666666666666\n")  # repr(1 / 6), not a median of stamp differences
    moved = tmp_path / "moved"
    shutil.copytree(roman_export, moved)
    with pytest.MonkeyPatch.context() as mp:
        d = _load(moved / "roman_params", "b", mp)
    f = direct_frames["b"][-1]
    np.testing.assert_allclose(d["gt"].T_WB(EPOCH_S + f.t), f.truth.T_world_body, atol=1e-6)
    assert len(d["img_data"].times) == FRAMES["b"]


@pytest.mark.parametrize("robot", ["a", "b"])
def test_the_reference_mapper_keeps_one_pose_per_exported_frame(
    roman_export: Path, direct_frames: dict, robot: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The reference's per-pair keys (``a12 b34``) index its mapper's poses, at ``np.arange(t0, tf, dt)`` (its
    runner's times): with the export's ``dt``, pose k is the exported frame k, as ``roman_align`` reads them."""
    d = _load(roman_export / "roman_params", robot, monkeypatch)
    img = d["img_data"]
    times = np.arange(img.t0, img.tf, d["dt"])
    t = np.array([f.t for f in direct_frames[robot]])
    assert len(t) - 1 <= len(times) <= len(t)  # the last frame is in or out as the float steps fall
    # its steps near 1.7e9 s drift by microseconds: pose k is still nearest frame k, far within the 0.01 s match
    np.testing.assert_allclose(times - EPOCH_S, t[: len(times)], atol=1e-5)
