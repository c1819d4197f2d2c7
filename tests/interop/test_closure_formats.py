"""Closure files of any system: their format told by the file, their stamps' clock, quaternion orders.

Hand-made files, values computed by hand: no run needed.
"""

from __future__ import annotations

import json
from pathlib import Path

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from roman_sim.core.errors import ConfigError
from roman_sim.interop.closure_files import closure_format, read_closure_file
from roman_sim.interop.closures import ClosureSet, read_closures
from roman_sim.interop.stamps import Clock, file_clock, matched, nearest_frames, no_frame, since_start_ns
from roman_sim.scoring.closure_conventions import reorder

INFO = " ".join(["1"] * 21)
Q = [float(v) for v in Rotation.from_euler("xyz", [0.1, -0.2, 0.7]).as_quat()]  # x y z w


def test_the_format_is_told_by_the_file(tmp_path: Path) -> None:
    (tmp_path / "ours.csv").write_text("# a comment\na,1.0,b,2.0,0,0,0,0,0,0,1\n", encoding="utf-8")
    (tmp_path / "kimera.csv").write_text(
        "robot1,pose1,robot2,pose2,qx,qy,qz,qw,tx,ty,tz,norm_bow_score,mono_inliers,stereo_inliers,stamp_ns\n",
        encoding="utf-8",
    )
    (tmp_path / "symbols.g2o").write_text(f"EDGE_SE3:QUAT {gtsam.symbol('a', 1)} 7 0 0 0 0 0 0 1 {INFO}\n")
    (tmp_path / "pair.g2o").write_text(f"# LC: 5\nEDGE_SE3:QUAT a1 b7 0 0 0 0 0 0 1 {INFO}\n")
    got = {p: closure_format(tmp_path / p) for p in ("ours.csv", "kimera.csv", "symbols.g2o", "pair.g2o")}
    assert got == {"ours.csv": "csv", "kimera.csv": "kimera_multi", "symbols.g2o": "g2o", "pair.g2o": "roman_align"}
    (tmp_path / "align" / "a_b").mkdir(parents=True)
    (tmp_path / "align" / "a_b" / "align.g2o").write_text("", encoding="utf-8")
    (tmp_path / "logs" / "kimera0").mkdir(parents=True)
    (tmp_path / "logs" / "kimera0" / "loop_closures.csv").write_text("", encoding="utf-8")
    assert closure_format(tmp_path / "align") == "roman_align" and closure_format(tmp_path / "logs") == "kimera_multi"


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("c.txt", "a 1 b 2", ": unknown file type '.txt' (allowed: a .csv file (this testbed's closures or "),
        ("c.csv", "time,x,y,z\n1,2,3,4\n", ":1: unknown CSV header 'time,x,y,z' (allowed: robot_a,t_a,robot_b,"),
        ("empty", None, ": a folder without closures (allowed: "),
    ],
)
def test_an_unknown_format_is_one_line(tmp_path: Path, name: str, text: str | None, message: str) -> None:
    path = tmp_path / name
    if text is None:
        path.mkdir()
    else:
        path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        read_closure_file(path, ["a", "b"])
    prefix = "--closures " if message.startswith(": unknown file") or "folder" in message else ""
    assert str(err.value).startswith(f"{prefix}{path}{message}"), str(err.value)


def test_a_w_first_file_read_with_its_order(tmp_path: Path) -> None:
    x, y, z, w = Q
    (tmp_path / "w.csv").write_text(f"a,1.0,b,2.0,1,2,3,{w!r},{x!r},{y!r},{z!r},7\n", encoding="utf-8")
    right = Rotation.from_quat(Q).as_matrix()
    got = read_closures(tmp_path / "w.csv", quaternion_order="wxyz").T_pa_pb[0]
    np.testing.assert_allclose(got[:3, :3], right, atol=1e-15)
    as_read = read_closures(tmp_path / "w.csv").T_pa_pb
    assert np.abs(as_read[0, :3, :3] - right).max() > 0.1  # read x first, it is another rotation
    np.testing.assert_allclose(reorder(as_read, "xyzw", "wxyz")[0], got, atol=1e-14)
    np.testing.assert_allclose(reorder(reorder(as_read, "xyzw", "wxyz"), "wxyz", "xyzw"), as_read, atol=1e-14)


def test_a_folder_of_pair_files_numbers_its_lines_as_one_text(tmp_path: Path) -> None:
    """Two pair files, each with its align.json: the second's lines follow the first's; ``locate`` maps back."""
    for pair, n in (("a_a", 1), ("a_b", 2)):
        d = tmp_path / "align" / pair
        d.mkdir(parents=True)
        edges = "".join(f"# LC: {5 + i}\nEDGE_SE3:QUAT a{i} b{i + 3} 1 2 3 0 0 0 1 {INFO}\n" for i in range(n))
        (d / "align.g2o").write_text(edges, encoding="utf-8")
        names = pair.split("_")
        entries = [{"seconds": [10 + i, 20 + i], "nanoseconds": [5, 500_000_000], "names": names} for i in range(n)]
        (d / "align.json").write_text(json.dumps(entries), encoding="utf-8")
    cs, fmt = read_closure_file(tmp_path / "align", ["a", "b"])
    assert fmt == "roman_align" and len(cs) == 3
    assert cs.files == (("a_a/align.g2o", 0), ("a_b/align.g2o", 2))
    assert cs.line.tolist() == [2, 4, 6] and cs.score.tolist() == [5, 5, 6]
    assert [cs.locate(int(n)) for n in cs.line] == [("a_a/align.g2o", 2), ("a_b/align.g2o", 2), ("a_b/align.g2o", 4)]
    assert [cs.robots[i] for i in cs.robot_b] == ["a", "b", "b"]
    np.testing.assert_allclose(cs.t_a, [10.000000005, 10.000000005, 11.000000005])
    np.testing.assert_allclose(cs.t_b, [20.5, 20.5, 21.5])
    whole = ClosureSet.concat([(cs, "x", 10)])
    assert whole.locate(3) == ("x", 3)


def test_a_files_clock_by_its_stamps_magnitude(tmp_path: Path) -> None:
    lines = np.asarray([2, 3, 4])
    assert file_clock("f", np.asarray([0.0, 5.0, 89.0]), lines, 7) == Clock(0)
    assert file_clock("f", np.asarray([1.7e9, 1.7e9 + 5]), lines[:2], 1_700_000_000 * 10**9).epoch_ns == 17 * 10**17
    with pytest.raises(ConfigError, match=r"^f:3: time 5.000000 s is on another clock than line 2's 1700000000.0"):
        file_clock("f", np.asarray([1.7e9, 5.0, 1.7e9]), lines, 1)
    # stamps of a 3-frame run at 1 Hz in nanoseconds since the start: two clocks, named as nanoseconds
    with pytest.raises(ConfigError, match="the file's stamps look like nanoseconds since the start$"):
        file_clock("f", np.asarray([0.0, 1e9, 2e9]), lines, 1, np.asarray([0.0, 1.0, 2.0]))
    ns = np.asarray([17 * 10**17 + 166_666_667], dtype=np.int64)
    assert since_start_ns(ns, Clock(17 * 10**17)).tolist() == [0.166666667]


def test_a_stamp_that_matches_no_frame_says_what_it_looks_like() -> None:
    frames = np.arange(0, 61) / 6.0  # 10 s at 6 Hz
    assert nearest_frames(frames, np.asarray([0.09, 0.07, 99.0])).tolist() == [1, 0, 60]
    assert matched(frames, np.asarray([0.0, 0.17, 0.2, 10.009])).tolist() == [True, True, False, True]
    late = no_frame(2.05, Clock(), "a", frames)
    assert late == (
        "time 2.050000 s of robot a matches no frame within 0.01 s (nearest frame 2.000000 s, 0.050000 s before it; "
        "the robot's frames run 0.000000 to 10.000000 s, every 0.166667 s; the file's clock: seconds since the "
        "robot's start)"
    )
    assert no_frame(2_000_000_000.0, Clock(), "a", frames).endswith(
        "; it looks like nanoseconds (2000000000 ns is 2.000000 s, a frame's time)"
    )
    assert "nanoseconds" not in no_frame(999.0, Clock(), "a", frames)  # 999 ns is near frame 0: not told apart
    epoch = no_frame(1.7e9 + 2.05, Clock(17 * 10**17), "a", frames)
    assert epoch.startswith("time 2.050000 s of robot a") and epoch.endswith(
        "the file's clock: the export's clock (epoch 1700000000000000000 ns taken off))"
    )
