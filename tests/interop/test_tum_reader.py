"""TUM RGB-D reader on a real-like folder (offset stamps, 100 Hz ground truth, no masks, no
odometry), odometry choices, intrinsics, bad input, and mapping frames whose truth has no ids."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.atomic import write_bytes, write_text
from roman_sim.core.errors import ConfigError, MappingError, StorageError
from roman_sim.core.geometry import make_T, rot_z
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import format_tum, read_tum
from roman_sim.interop.associate import associate
from roman_sim.interop.images import encode_png
from roman_sim.interop.tum_reader import read_tum_sequence

T0 = 1305031102.175304  # a TUM-like Unix time stamp
N_IMAGES, W, H = 12, 32, 24
R_FLU_RDF = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def _T_world_cam(t: float) -> np.ndarray:
    s = t - T0
    return make_T(rot_z(0.2 * s) @ R_FLU_RDF, [s, 0.5 * s, 1.2])


def _depth(k: int) -> np.ndarray:
    d = np.full((H, W), 10000 + 100 * k, dtype=np.uint16)  # 2 m + 2 cm per frame
    d[:3, :4] = 0
    return d


@pytest.fixture(scope="module")
def real_like(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """RGB at 30 Hz, depth 12 ms later, ground truth at 100 Hz starting earlier, camera.txt."""
    d = tmp_path_factory.mktemp("tum_real") / "rgbd_dataset_freiburg_like"
    rgb_rows, depth_rows = [], []
    for k in range(N_IMAGES):
        tr, td = T0 + k / 30, T0 + k / 30 + 0.012
        write_bytes(d / "rgb" / f"{tr:.6f}.png", encode_png(np.full((H, W, 3), k, dtype=np.uint8)))
        write_bytes(d / "depth" / f"{td:.6f}.png", encode_png(_depth(k)))
        rgb_rows.append(f"{tr:.6f} rgb/{tr:.6f}.png")
        depth_rows.append(f"{td:.6f} depth/{td:.6f}.png")
    write_text(d / "rgb.txt", "# color images\n# file: 'x.bag'\n# timestamp filename\n" + "\n".join(rgb_rows) + "\n")
    write_text(d / "depth.txt", "# depth maps\n# x\n# timestamp filename\n" + "\n".join(depth_rows) + "\n")
    t_gt = T0 - 0.05 + np.arange(60) / 100.0
    write_text(
        d / "groundtruth.txt",
        "# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n"
        + format_tum(Trajectory(t_gt, np.stack([_T_world_cam(t) for t in t_gt]))),
    )
    write_text(d / "camera.txt", "# fx fy cx cy d0 d1 d2 d3 d4\n30.0 31.0 15.5 11.5 0 0 0 0 0\n")
    return d


def test_association_and_truth_without_ids(real_like: Path) -> None:
    seq = read_tum_sequence(real_like, robot="fr", odometry="groundtruth")
    frames = list(seq.frames())
    assert len(frames) == N_IMAGES and not seq.has_masks
    for k, f in enumerate(frames):
        assert f.robot == "fr" and f.index == k and abs(f.t - (T0 + k / 30)) < 1e-6
        np.testing.assert_array_equal(f.rgb, np.full((H, W, 3), k, dtype=np.uint8))
        np.testing.assert_allclose(f.depth[5, 5], 2.0 + 0.02 * k, atol=1e-6)
        assert f.depth[0, 0] == 0.0
        assert f.truth is not None and f.truth.object_ids is None
        # nearest 100 Hz ground-truth sample: at most 5 ms away, here the pose moves ~1.1 m/s
        gt_t = T0 - 0.05 + np.round((f.t - T0 + 0.05) * 100) / 100
        np.testing.assert_allclose(f.truth.T_world_body @ f.T_body_cam, _T_world_cam(gt_t), atol=1e-6)
        np.testing.assert_allclose(f.T_odom_body, f.truth.T_world_body, atol=1e-12)
        np.testing.assert_allclose(f.T_body_cam[:3, :3], R_FLU_RDF)  # default: optical camera on a level body
    assert frames[0].intrinsics.fx == 30.0 and (frames[0].intrinsics.width, frames[0].intrinsics.height) == (W, H)


def test_tolerance_drops_frames(real_like: Path) -> None:
    with pytest.raises(StorageError, match="no frame"):
        read_tum_sequence(real_like, odometry="groundtruth", max_time_diff_s=0.01)
    assert len(read_tum_sequence(real_like, odometry="groundtruth", max_frames=5)) == 5


def test_odometry_choices(real_like: Path, tmp_path: Path) -> None:
    auto = read_tum_sequence(real_like, robot="fr", seed=3)  # no odometry.txt: drifted ground truth
    again = read_tum_sequence(real_like, robot="fr", seed=3)
    other = read_tum_sequence(real_like, robot="fr", seed=4)
    np.testing.assert_array_equal(auto.T_odom_body, again.T_odom_body)
    assert np.abs(auto.T_odom_body - other.T_odom_body).max() > 1e-6
    assert np.abs(auto.T_odom_body - auto.T_world_body).max() > 1e-6
    zero = read_tum_sequence(real_like, robot="fr", odometry="drift", drift="zero")
    # zero drift: odometry = truth relative to the gravity-aligned start (identity x, y, z, yaw)
    rel = np.linalg.inv(zero.T_world_body[0]) @ zero.T_world_body
    np.testing.assert_allclose(np.linalg.inv(zero.T_odom_body[0]) @ zero.T_odom_body, rel, atol=1e-9)
    own = tmp_path / "vio.txt"
    gt = read_tum(real_like / "groundtruth.txt")
    write_text(own, format_tum(Trajectory(gt.t, gt.T @ make_T(t=[0.0, 0.0, 1.0]))))
    seq = read_tum_sequence(real_like, odometry=str(own))
    # the file's camera sits 1 m ahead along its optical axis: body positions move by R_world_cam @ z
    ahead = seq.T_world_body[:, :3, :3] @ seq.T_body_cam[:3, :3] @ np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(seq.T_odom_body[:, :3, 3] - seq.T_world_body[:, :3, 3], ahead, atol=1e-6)


def test_intrinsics_given_or_missing(real_like: Path, tmp_path: Path) -> None:
    seq = read_tum_sequence(real_like, odometry="groundtruth", intrinsics={"fx": 20, "fy": 20, "cx": 15.5, "cy": 11.5})
    assert seq.intrinsics.fx == 20.0
    bare = tmp_path / "bare"
    for name in ("rgb.txt", "depth.txt", "groundtruth.txt"):
        write_text(bare / name, (real_like / name).read_text())
    for p in itertools.chain((real_like / "rgb").iterdir(), (real_like / "depth").iterdir()):
        write_bytes(bare / p.parent.name / p.name, p.read_bytes())
    with pytest.raises(ConfigError, match="intrinsics"):
        read_tum_sequence(bare, odometry="groundtruth")
    write_text(bare / "camera.txt", "30 31 15.5 11.5 0.26 -0.95 0 0 1.16\n")
    with pytest.raises(StorageError, match="distortion"):
        read_tum_sequence(bare, odometry="groundtruth")
    write_text(bare / "camera.txt", "30 31 15.5 11.5\n640 480\n")
    with pytest.raises(StorageError, match="does not match"):
        read_tum_sequence(bare, odometry="groundtruth")


def test_bad_input_names_the_problem(real_like: Path, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="not a folder"):
        read_tum_sequence(tmp_path / "nowhere")
    with pytest.raises(StorageError, match="depth.txt"):
        read_tum_sequence(tmp_path)
    with pytest.raises(ConfigError, match="odometry_source|odometry"):
        read_tum_sequence(real_like, odometry="no_such_file.txt")
    with pytest.raises(ConfigError, match="unknown key"):
        read_tum_sequence(real_like, depth_scael=5000)
    broken = tmp_path / "broken"
    write_text(broken / "depth.txt", "1.0 depth/1.png\n2.0 depth/2.png\n")
    write_text(broken / "groundtruth.txt", format_tum(Trajectory(np.array([1.0, 2.0]), np.stack([np.eye(4)] * 2))))
    write_text(broken / "camera.txt", "10 10 1.5 1.5\n")
    write_bytes(broken / "depth" / "1.png", encode_png(np.ones((4, 4), dtype=np.uint16)))
    seq = read_tum_sequence(broken, odometry="groundtruth")
    it = seq.frames()
    assert next(it).depth.shape == (4, 4)
    with pytest.raises(StorageError, match="not found"):
        next(it)
    write_bytes(broken / "depth" / "1.png", encode_png(np.ones((4, 4), dtype=np.uint8)))
    with pytest.raises(StorageError, match="16-bit"):
        next(read_tum_sequence(broken, odometry="groundtruth").frames())


def _brute_force_associate(a: np.ndarray, b: np.ndarray, tol: float) -> list[tuple[int, int]]:
    """The TUM benchmark's associate.py: every pair within tol, greedily closest first."""
    cands = sorted((abs(x - y), i, j) for i, x in enumerate(a) for j, y in enumerate(b) if abs(x - y) < tol)
    ua, ub, out = set(), set(), []
    for _, i, j in cands:
        if i not in ua and j not in ub:
            ua.add(i)
            ub.add(j)
            out.append((i, j))
    return sorted(out)


def test_associate_matches_the_tum_tool() -> None:
    rng = np.random.default_rng(0)
    for trial in range(30):
        a = np.sort(rng.uniform(0, 2, rng.integers(0, 40)))
        b = np.sort(np.concatenate([a[: len(a) // 2] + rng.normal(0, 0.01, len(a) // 2), rng.uniform(0, 2, 10)]))
        i, j = associate(a, b, 0.02)
        assert list(zip(i.tolist(), j.tolist())) == _brute_force_associate(a, b, 0.02), trial
    i, j = associate(np.array([3.0, 1.0, 2.0]), np.array([2.001, 0.999]), 0.02)  # unsorted input
    assert list(zip(i.tolist(), j.tolist())) == [(1, 1), (2, 0)]


class SideFileSegmenter:
    """A user's segmenter that never reads frame.truth: it loads the exported mask PNGs."""

    def __init__(self, folder: Path) -> None:
        from roman_sim.interop.associate import read_list

        self.folder = folder
        self.files = read_list(folder / "masks.txt")[1]

    def segment(self, frame):  # the Segmenter protocol
        from roman_sim.interop.images import mask_to_ids, read_png
        from roman_sim.mapping.mask import Mask

        ids = mask_to_ids(read_png(self.folder / self.files[frame.index]))
        return [Mask(ids == k) for k in np.unique(ids) if k >= 0 and np.count_nonzero(ids == k) >= 20]


def test_mapping_frames_whose_truth_has_no_ids(tum_export: Path) -> None:
    from roman_sim.frontend.segmenter import simulated_segmenter
    from roman_sim.mapping.mapper import Mapper
    from roman_sim.mapping.submap import SubmapConfig, build_submaps
    from roman_sim.mapping.tracker import MappingConfig

    seq = read_tum_sequence(tum_export / "a", robot="a", masks=False)
    assert not seq.has_masks
    mapper = Mapper(MappingConfig(), SideFileSegmenter(tum_export / "a"))
    for f in seq.frames():
        assert f.truth is not None and f.truth.object_ids is None
        mapper.process(f)
    smap = mapper.finish()
    assert len(smap) > 0 and smap.T_world_body is not None
    np.testing.assert_allclose(smap.T_world_body, seq.T_world_body)
    assert all(not s.truth_counts and s.majority_id == -1 for s in smap.segments)
    subs = build_submaps(smap, SubmapConfig())
    assert subs and all(s.truth is not None and np.all(s.truth.object_ids == -1) for s in subs)
    with pytest.raises(MappingError, match="instance labels"):
        Mapper(MappingConfig(), simulated_segmenter("perfect", seed=0)).process(next(seq.frames()))
