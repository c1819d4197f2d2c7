"""Recordings: round trip, TUM trajectories, atomic writes, clear errors for bad folders."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from roman_sim.core.errors import RecordingError
from roman_sim.core.geometry import make_T, rot_z
from roman_sim.core.sensors import Frame, FrameTruth
from roman_sim.core.tum import read_tum
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.recording import read_recording, recording_info, write_recording

CAM = CameraConfig(width=16, height=12)


def _frames(n: int, rgb: bool = True, robot: str = "r1") -> list[Frame]:
    rng = np.random.default_rng(0)
    out = []
    for i in range(n):
        depth = rng.uniform(0.3, 8.0, (12, 16)).astype(np.float32)
        depth[0, :3] = 0.0
        ids = rng.integers(-1, 40, (12, 16)).astype(np.int32)
        img = rng.integers(0, 256, (12, 16, 3)).astype(np.uint8) if rgb else None
        T_wb = make_T(rot_z(0.1 * i), [i * 0.2, 1.0, 0.3])
        T_ob = make_T(rot_z(0.1 * i + 0.01), [i * 0.21, 0.0, 0.0])
        out.append(
            Frame(robot, i, i / 6.0, img, depth, T_ob, CAM.T_body_cam(), CAM.intrinsics(), FrameTruth(ids, T_wb))
        )
    return out


def test_round_trip(tmp_path: Path) -> None:
    frames = _frames(7)
    rec = write_recording(iter(frames), tmp_path / "rec", chunk_size=3)
    info = recording_info(rec)
    assert info.frame_count == 7 and len(info.chunks) == 3 and info.robot == "r1" and info.extra is None
    back = list(read_recording(rec))
    assert len(back) == 7
    for a, b in zip(frames, back):
        assert (a.robot, a.index, a.t, a.intrinsics) == (b.robot, b.index, b.t, b.intrinsics)
        np.testing.assert_allclose(b.depth, a.depth, atol=0.0005 + 1e-6)  # millimetre storage
        assert np.all((b.depth == 0) == (a.depth == 0))
        np.testing.assert_array_equal(b.truth.object_ids, a.truth.object_ids)
        assert b.truth.object_ids.dtype == np.int32
        np.testing.assert_array_equal(b.rgb, a.rgb)
        np.testing.assert_array_equal(b.truth.T_world_body, a.truth.T_world_body)
        np.testing.assert_array_equal(b.T_odom_body, a.T_odom_body)
        np.testing.assert_allclose(b.T_body_cam, a.T_body_cam)
    true = read_tum(rec / "traj_true.tum")
    np.testing.assert_allclose(true.T, [f.truth.T_world_body for f in frames], atol=1e-8)
    odom = read_tum(rec / "traj_odom.tum")
    np.testing.assert_allclose(odom.T, [f.T_odom_body for f in frames], atol=1e-8)
    np.testing.assert_allclose(odom.t, [f.t for f in frames], atol=1e-9)


def test_same_frames_same_bytes(tmp_path: Path) -> None:
    a = write_recording(_frames(4, rgb=False), tmp_path / "a")
    b = write_recording(_frames(4, rgb=False), tmp_path / "b")
    for f in sorted(p.name for p in a.iterdir()):
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    assert next(read_recording(a)).rgb is None


def test_interrupted_write_leaves_nothing(tmp_path: Path) -> None:
    def broken():
        yield from _frames(3)
        raise RuntimeError("renderer died")

    with pytest.raises(RuntimeError):
        write_recording(broken(), tmp_path / "rec", chunk_size=2)
    assert list(tmp_path.iterdir()) == []


def test_write_errors(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="no frames"):
        write_recording([], tmp_path / "empty")
    write_recording(_frames(2), tmp_path / "rec")
    with pytest.raises(RecordingError, match="already exists"):
        write_recording(_frames(2), tmp_path / "rec")
    write_recording(_frames(3), tmp_path / "rec", overwrite=True)
    assert recording_info(tmp_path / "rec").frame_count == 3
    mixed = _frames(2) + _frames(1, robot="r2")
    with pytest.raises(RecordingError, match="differ"):
        write_recording(mixed, tmp_path / "mixed")
    assert not (tmp_path / "mixed").exists()


def test_read_errors(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="meta.json missing"):
        recording_info(tmp_path / "nope")
    rec = write_recording(_frames(4), tmp_path / "rec", chunk_size=2)
    meta = json.loads((rec / "meta.json").read_text())
    (rec / "meta.json").write_text(json.dumps({**meta, "format_version": 99}))
    with pytest.raises(RecordingError, match="version 99"):
        list(read_recording(rec))
    (rec / "meta.json").write_text("{not json")
    with pytest.raises(RecordingError, match="corrupt meta.json"):
        recording_info(rec)
    (rec / "meta.json").write_text(json.dumps({**meta, "frame_count": "four"}))
    with pytest.raises(RecordingError, match=r"meta.json: field frame_count: expected an integer.*incomplete metadata"):
        recording_info(rec)
    (rec / "meta.json").write_text(json.dumps(meta))
    (rec / "chunk_00001.npz").write_bytes(b"garbage")
    frames = read_recording(rec)
    assert next(frames).index == 0
    with pytest.raises(RecordingError, match="chunk_00001.npz: corrupt chunk"):
        list(frames)
    (rec / "chunk_00001.npz").unlink()
    with pytest.raises(RecordingError, match="missing chunk"):
        recording_info(rec)


def test_record_a_simulated_run(tmp_path: Path, tiny_world) -> None:
    from roman_sim.core.sensors import FrameSource
    from roman_sim.sim.paths import PathConfig
    from roman_sim.sim.recording import Recording, RecordingOrigin, write_recording
    from roman_sim.sim.robot import RobotConfig
    from roman_sim.sim.source import robot_sources

    cfg = RobotConfig(
        name="a",
        path=PathConfig(kind="loop", radius_m=5.0),
        camera=CameraConfig(width=64, height=48),
        max_duration_s=1.0,
        render_rgb=False,
    )
    source = robot_sources(tiny_world, [cfg], 0)[0]
    rec = write_recording(source.frames(), tmp_path / "run", origin=RecordingOrigin("tiny", 0))
    assert recording_info(rec).extra == RecordingOrigin("tiny", 0)
    frames = list(read_recording(rec))
    live = list(source.frames())
    assert len(frames) == len(live) == len(source) == 7
    recorded = Recording(rec)  # the recording is a frame source with the robot's name, camera and length
    assert isinstance(recorded, FrameSource) and (recorded.name, len(recorded)) == ("a", 7)
    assert recorded.intrinsics == source.intrinsics
    np.testing.assert_array_equal(recorded.T_body_cam, source.T_body_cam)
    assert [f.index for f in recorded.frames([1, 5])] == [1, 5]
    np.testing.assert_array_equal(frames[-1].truth.object_ids, live[-1].truth.object_ids)
    np.testing.assert_allclose(frames[-1].depth, live[-1].depth, atol=0.0005 + 1e-6)
