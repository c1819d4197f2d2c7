"""The view's camera frames: a subsample of a run's recordings, evenly spaced, ends kept."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from roman_sim.core.geometry import make_T
from roman_sim.core.sensors import Frame, FrameTruth
from roman_sim.pipeline.scenario import ScenarioRobot
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.recording import write_recording
from roman_sim.viz.camera_frames import camera_frames, subsample

CAM = CameraConfig(width=16, height=12)


def _frames(n: int) -> list[Frame]:
    return [
        Frame(
            "r",
            i,
            i / 6.0,
            np.full((12, 16, 3), i, np.uint8),
            np.full((12, 16), 2.0, np.float32),
            make_T(t=[0.1 * i, 0, 0]),
            CAM.T_body_cam(),
            CAM.intrinsics(),
            FrameTruth(np.full((12, 16), i % 3, np.int32), make_T(t=[0.1 * i, 1, 0])),
        )
        for i in range(n)
    ]


def test_subsample() -> None:
    np.testing.assert_array_equal(subsample(10, 4), [0, 3, 6, 9])
    np.testing.assert_array_equal(subsample(3, 10), [0, 1, 2])
    assert len(subsample(0, 5)) == 0 and len(subsample(7, 0)) == 0


def test_recorded_frames_are_used(tmp_path: Path) -> None:
    write_recording(_frames(10), tmp_path / "recordings" / "r", chunk_size=4)
    sc = SimpleNamespace(robots=[ScenarioRobot(name="r"), ScenarioRobot(name="q")], seed=0)
    streams = camera_frames(tmp_path, sc, None, 4)
    assert list(streams) == ["r"]  # q has no recording and there is no world to render it
    got = list(streams["r"])
    assert [f.index for f in got] == [0, 3, 6, 9]
    assert [int(f.rgb[0, 0, 0]) for f in got] == [0, 3, 6, 9]
    np.testing.assert_array_equal(got[1].truth.object_ids, np.full((12, 16), 0, np.int32))
