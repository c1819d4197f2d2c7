"""An odometry file brought back in: matched to a robot's frames by time, on either clock; bad files in one line."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import make_T, rot_z
from roman_sim.core.sensors import Frame, Intrinsics
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import format_tum, write_tum
from roman_sim.interop.base import EXPORT_EPOCH_NS
from roman_sim.interop.odometry_in import OdometryFile, WithOdometry, match_odometry

TIMES = np.arange(20) / 6.0  # a robot's frames: 6 Hz for 19/6 s
T_BODY_CAM = make_T(rot_z(0.3), [0.2, 0.0, 0.4])


def _poses(n: int) -> np.ndarray:
    return np.stack([make_T(rot_z(0.1 * k), [0.5 * k, 0.02 * k * k, 0.01 * k]) for k in range(n)])


def _file(tmp_path: Path, t: np.ndarray, T: np.ndarray, name: str = "odom.tum") -> OdometryFile:
    write_tum(tmp_path / name, Trajectory(t, T))
    return OdometryFile(file=tmp_path / name)


def test_poses_come_back_at_their_frames_on_either_clock_and_in_either_frame(tmp_path: Path) -> None:
    T = _poses(len(TIMES))
    for t in (TIMES, TIMES + EXPORT_EPOCH_NS / 1e9):  # seconds since the start, the export's clock
        got = match_odometry(_file(tmp_path, t, T), "a", TIMES, T_BODY_CAM)
        np.testing.assert_array_equal(got.keep, np.arange(len(TIMES)))
        np.testing.assert_allclose(got.T_odom_body, T, atol=1e-8)  # nine decimals in the file
    assert got.clock.epoch_ns == EXPORT_EPOCH_NS
    camera = _file(tmp_path, TIMES, T @ T_BODY_CAM).model_copy(update={"frame": "camera"})
    np.testing.assert_allclose(match_odometry(camera, "a", TIMES, T_BODY_CAM).T_odom_body, T, atol=1e-8)


def test_a_denser_file_gives_each_frame_its_nearest_pose(tmp_path: Path) -> None:
    t = np.arange(200) / 60.0  # ten poses per frame, as at an IMU's rate
    T = _poses(len(t))
    got = match_odometry(_file(tmp_path, t, T), "a", TIMES, T_BODY_CAM)
    np.testing.assert_allclose(got.T_odom_body, T[::10][: len(TIMES)], atol=1e-8)


def test_a_file_that_starts_late_leaves_out_the_frames_before_it(tmp_path: Path) -> None:
    T = _poses(len(TIMES))
    late = _file(tmp_path, TIMES[5:], T[5:])
    with pytest.raises(ConfigError) as err:
        match_odometry(late, "a", TIMES, T_BODY_CAM)
    assert str(err.value) == (
        f"{late.file}: covers 75% of robot a's frames (15 of 20 within 0.01 s; the file runs 0.833 to 3.167 s, the "
        "robot 0.000 to 3.167 s); required: at least 90% (odometry.min_share)"
    )
    got = match_odometry(late.model_copy(update={"min_share": 0.75}), "a", TIMES, T_BODY_CAM)
    np.testing.assert_array_equal(got.keep, np.arange(5, 20))
    np.testing.assert_allclose(got.T_odom_body, T[5:], atol=1e-8)


def test_bad_stamps_are_named_in_one_line(tmp_path: Path) -> None:
    T = _poses(len(TIMES))
    late = TIMES.copy()
    late[3] += 0.05  # 50 ms late: between two frames
    with pytest.raises(ConfigError, match=r"odom.tum:4: time 0\.550000 s of robot a matches no frame within 0\.01 s"):
        match_odometry(_file(tmp_path, late, T), "a", TIMES, T_BODY_CAM)
    (tmp_path / "ns.tum").write_text(format_tum(Trajectory(TIMES * 1e9, T)))  # nanoseconds since the start
    with pytest.raises(ConfigError, match=r"ns.tum:20: time 3166666667 is in nanoseconds \(3\.166667 s"):
        match_odometry(OdometryFile(file=tmp_path / "ns.tum"), "a", TIMES, T_BODY_CAM)
    ns_1970 = np.round(EXPORT_EPOCH_NS + TIMES * 1e9)  # nanoseconds on the export's clock
    (tmp_path / "ns1970.tum").write_text(format_tum(Trajectory(ns_1970, T)))
    with pytest.raises(ConfigError, match=r"ns1970.tum:1: .*it looks like nanoseconds"):
        match_odometry(OdometryFile(file=tmp_path / "ns1970.tum"), "a", TIMES, T_BODY_CAM)
    with pytest.raises(ConfigError, match=r"odometry.file .*nowhere.tum: cannot be read"):
        match_odometry(OdometryFile(file=tmp_path / "nowhere.tum"), "a", TIMES, T_BODY_CAM)


def test_a_file_changed_after_the_run_resolved_it_is_refused(tmp_path: Path) -> None:
    cfg = _file(tmp_path, TIMES, _poses(len(TIMES)))
    pinned = cfg.model_copy(update={"sha256": cfg.digest()})
    assert len(match_odometry(pinned, "a", TIMES, T_BODY_CAM).keep) == len(TIMES)
    with (tmp_path / "odom.tum").open("a") as fh:
        fh.write("# edited\n")
    with pytest.raises(ConfigError, match="changed since the run read it"):
        match_odometry(pinned, "a", TIMES, T_BODY_CAM)


class _Frames:
    """A frame source of ``n`` frames whose odometry is the identity."""

    name, intrinsics, T_body_cam = "a", Intrinsics(4, 3, 2.0, 2.0, 1.5, 1.0), T_BODY_CAM

    def __init__(self, n: int) -> None:
        self.n = n

    def __len__(self) -> int:
        return self.n

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[Frame]:
        for k in range(self.n) if indices is None else indices:
            yield Frame(
                "a", k, float(TIMES[k]), None, np.ones((3, 4), np.float32), np.eye(4), T_BODY_CAM, self.intrinsics
            )


def test_frames_carry_the_poses_from_outside_and_keep_their_index(tmp_path: Path) -> None:
    T = _poses(len(TIMES))
    cfg = _file(tmp_path, TIMES[2:], T[2:]).model_copy(update={"min_share": 0.5})
    src = WithOdometry(_Frames(len(TIMES)), match_odometry(cfg, "a", TIMES, T_BODY_CAM))
    frames = list(src.frames())
    assert len(src) == len(frames) == 18 and [f.index for f in frames] == list(range(2, 20))
    np.testing.assert_allclose(np.stack([f.T_odom_body for f in frames]), T[2:], atol=1e-8)
    picked = list(src.frames([0, 4]))  # this source's own positions
    assert [f.index for f in picked] == [2, 6]
    np.testing.assert_allclose(picked[1].T_odom_body, T[6], atol=1e-8)


def test_a_plain_path_is_a_file() -> None:
    assert OdometryFile.model_validate("x.tum") == OdometryFile(file=Path("x.tum"))
