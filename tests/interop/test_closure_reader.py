"""The closure readers stream their files and check every value where it is read.

The readers return arrays (``ClosureSet``); on small files they give what the former readers
gave: per line, the pose of ``pose_from_xyz_quat`` (CSV) or of gtsam's ``readG2o`` (g2o),
to the last bit of rounding, and the same robots, times, scores and lines. They read one
line at a time from any iterable: a malformed line stops them before they pull the next.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from pathlib import Path

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.tum import read_tum
from roman_sim.interop.associate import read_list
from roman_sim.interop.closures import (
    Closure,
    ClosureSet,
    parse_csv_closures,
    parse_g2o_closures,
    pose_from_xyz_quat,
    read_closures,
    read_pose_csv,
    read_times_file,
    write_g2o_closures,
)

CSV = """# a system's loop closures
robot_a,t_a,robot_b,t_b,x,y,z,qx,qy,qz,qw,score

a,1.5,b,2.25,1.0,-2.0,0.5,0.0,0.0,0.0,1.0,7
 b , 3.0 , a , 0.5 ,10.25,0,-1,0.5,0.5,0.5,0.5,
a,4.0,a,9.0,0,0,0,0.1,0.2,0.3,0.9273618495495703,0
b,0.0,b,1.0,-3,4,0.125,0,0.6,0,0.8000040000000000
"""


def _expected_csv() -> list[tuple[str, float, str, float, list[float], int | None, int]]:
    rows = []
    for n, text in enumerate(CSV.splitlines(), start=1):
        cells = [c.strip() for c in text.split(",")]
        if len(cells) < 11 or cells[0] in ("robot_a",) or cells[0].startswith("#"):
            continue
        score = int(cells[11]) if len(cells) == 12 and cells[11] else None
        rows.append((cells[0], float(cells[1]), cells[2], float(cells[3]), [float(c) for c in cells[4:11]], score, n))
    return rows


def _assert_same(got: ClosureSet, expected: list[Closure], atol: float) -> None:
    assert len(got) == len(expected)
    for g, e in zip(got, expected):
        assert (g.robot_a, g.t_a, g.robot_b, g.t_b, g.score, g.line) == (
            e.robot_a,
            e.t_a,
            e.robot_b,
            e.t_b,
            e.score,
            e.line,
        )
        assert np.array_equal(g.T_pa_pb[:3, 3], e.T_pa_pb[:3, 3]) and np.array_equal(g.T_pa_pb[3], [0, 0, 0, 1])
        np.testing.assert_allclose(g.T_pa_pb, e.T_pa_pb, rtol=0, atol=atol)


def test_a_csv_file_reads_as_the_former_reader_read_it(tmp_path: Path) -> None:
    path = tmp_path / "c.csv"
    path.write_text(CSV, encoding="utf-8")
    expected = [
        Closure(a, ta, b, tb, pose_from_xyz_quat(path, n, v), s, n) for a, ta, b, tb, v, s, n in _expected_csv()
    ]
    assert [e.line for e in expected] == [4, 5, 6, 7] and [e.score for e in expected] == [7, None, 0, None]
    got = read_closures(path)
    _assert_same(got, expected, atol=1e-15)
    assert got.robots == ("a", "b") and got.T_pa_pb.shape == (4, 4, 4)
    # the third line's quaternion has norm 1 within 1e-5: accepted, and a rotation
    np.testing.assert_allclose(got[3].T_pa_pb[:3, :3] @ got[3].T_pa_pb[:3, :3].T, np.eye(3), atol=1e-12)
    # any iterable of lines, e.g. a generator: the same closures
    _assert_same(parse_csv_closures((ln for ln in CSV.splitlines(keepends=True)), path), expected, atol=0.0)


def _lines(head: list[str], bad: str, pulled: list[int]) -> Iterator[str]:
    """``head``, then ``bad``, then a million more good lines, counting every line pulled."""
    for line in itertools.chain(head, [bad], itertools.repeat(head[-1], 10**6)):
        pulled[0] += 1
        yield line


def test_the_csv_reader_reads_one_line_at_a_time() -> None:
    """A malformed third line stops the reader after it pulled three lines, not the file."""
    pulled = [0]
    good = "a,1.5,b,2.25,1.0,-2.0,0.5,0.0,0.0,0.0,1.0,7\n"
    with pytest.raises(ConfigError, match=r"^stream:3: field x: 1e\+308 m is out of range"):
        parse_csv_closures(_lines([good, good], "a,1,b,2,1e308,0,0,0,0,0,1,7\n", pulled), "stream")
    assert pulled[0] == 3


def _closures() -> list[Closure]:
    out = []
    for i in range(6):
        T = np.eye(4)
        T[:3, :3] = Rotation.from_rotvec([0.1 * i, -0.2, 0.3 * i]).as_matrix()
        T[:3, 3] = [i, -2.0 * i, 0.25]
        out.append(Closure("ab"[i % 2], 0.5 * i, "ab"[(i // 2) % 2], 1.0 + i, T, None if i == 3 else i))
    return out


def test_a_g2o_file_reads_as_gtsams_reader_reads_it(tmp_path: Path) -> None:
    path, times = tmp_path / "c.g2o", tmp_path / "c.time.txt"
    write_g2o_closures(path, times, _closures(), ["a", "b"])
    odometry = (  # a vertex and an odometry edge (keyframes 0 -> 1 of robot a, no LC comment): not closures
        f"VERTEX_SE3:QUAT {gtsam.symbol('a', 0)} 0 0 0 0 0 0 1\n"
        f"EDGE_SE3:QUAT {gtsam.symbol('a', 0)} {gtsam.symbol('a', 1)} 1 0 0 0 0 0 1 {' '.join(['1'] * 21)}\n"
    )
    path.write_text(odometry + path.read_text(encoding="utf-8"), encoding="utf-8")
    graph, _ = gtsam.readG2o(str(path), True)
    factors = [graph.at(i) for i in range(graph.size())][1:]  # gtsam reads the odometry edge too
    kept = {(c.robot_a, c.t_a, c.robot_b, c.t_b) for c in _closures()}
    tv = {}  # (robot id, index) -> time, from the timestamps file
    for line in times.read_text(encoding="utf-8").splitlines():
        rid, idx, ns, _ = line.split()
        tv[(int(rid), int(idx))] = int(ns) / 1e9
    expected, lines = [], [n for n, ln in enumerate(path.read_text().splitlines(), 1) if ln.startswith("EDGE")][1:]
    scores = [c.score for c in _closures()]
    for f, n, s in zip(factors, lines, scores):
        ends = []
        for key in f.keys():
            sym = gtsam.Symbol(key)
            chr_ = sym.chr() if isinstance(sym.chr(), int) else ord(sym.chr())
            ends.append(("ab"[chr_ - ord("a")], tv[(chr_ - ord("a"), int(sym.index()))]))
        expected.append(Closure(ends[0][0], ends[0][1], ends[1][0], ends[1][1], f.measured().matrix(), s, n))
    assert {(e.robot_a, e.t_a, e.robot_b, e.t_b) for e in expected} == kept
    got = read_closures(path, times, ["a", "b"])
    _assert_same(got, expected, atol=2e-15)
    with path.open(encoding="utf-8") as fh:  # a non-seekable stream of its lines gives the same
        streamed = parse_g2o_closures(iter(fh.readline, ""), path, read_times_file(times), ["a", "b"])
    _assert_same(streamed, list(got), atol=0.0)


def test_the_g2o_reader_reads_one_line_at_a_time(tmp_path: Path) -> None:
    times = tmp_path / "t.txt"
    times.write_text("0 0 1000000000\n1 0 2000000000\n", encoding="utf-8")
    info = " ".join(["1"] * 21)
    good = f"EDGE_SE3:QUAT {gtsam.symbol('a', 0)} {gtsam.symbol('b', 0)} 1 2 0 0 0 0 1 {info}\n"
    bad = f"EDGE_SE3:QUAT {gtsam.symbol('a', 0)} {gtsam.symbol('b', 0)} 1 2 0 0 0 0 1 {info[:-1]}nan\n"
    pulled = [0]
    with pytest.raises(ConfigError, match="^stream:2: field information entry 21: nan is not a finite number$"):
        parse_g2o_closures(_lines([good], bad, pulled), "stream", read_times_file(times), ["a", "b"])
    assert pulled[0] == 2


def test_a_timestamps_file_keeps_the_last_time_of_a_key(tmp_path: Path) -> None:
    path = tmp_path / "t.txt"
    path.write_text("# robot index ns\n0 3 3000000000 a\n1 0 5000000000\n0 3 4000000000\n", encoding="utf-8")
    kt = read_times_file(path)
    keys = np.asarray([gtsam.symbol("a", 3), gtsam.symbol("b", 0), gtsam.symbol("b", 1)], dtype=np.uint64)
    t, found = kt.lookup(keys)
    assert found.tolist() == [True, True, False] and t[:2].tolist() == [4.0, 5.0]


POSE = ["1", "2", "0", "0", "0", "0", "1"]  # x y z qx qy qz qw


def _csv(**fields: str) -> str:
    cells = {
        "robot_a": "a",
        "t_a": "1",
        "robot_b": "b",
        "t_b": "2",
        **dict(zip(("x", "y", "z", "qx", "qy", "qz", "qw"), POSE)),
    }
    cells.update(fields)
    return ",".join(cells.values()) + ",5"


CSV_VALUES = {
    "huge x": (_csv(x="1e308"), "field x: 1e+308 m is out of range (allowed: a magnitude of at most 1e+09 m)"),
    "inf y": (_csv(y="inf"), "field y: inf is not a finite number"),
    "nan qw": (_csv(qw="nan"), "field qw: nan is not a finite number"),
    "huge time": (_csv(t_b="1e308"), "field t_b: 1e+308 s is out of range (allowed: a magnitude of at most 1e+11 s)"),
    "nan time": (_csv(t_a="nan"), "field t_a: nan is not a finite number"),
    "quaternion far from 1": (_csv(qw="2"), "quaternion norm 2: a rigid relative pose needs a unit quaternion"),
}


TUM_VALUES = {
    "huge tx": ("0 1e308 0 0 0 0 0 1", "field tx: 1e+308 m is out of range (allowed: a magnitude of at most 1e+09 m)"),
    "inf qz": ("0 0 0 0 0 0 inf 1", "field qz: inf is not a finite number"),
    "huge stamp": ("1e300 0 0 0 0 0 0 1", "field timestamp: 1e+300 s is out of range"),
    "quaternion far from 1": (
        "0 0 0 0 0 0 0 2",
        "fields qx qy qz qw: quaternion norm 2, not a rotation (allowed: a norm within 0.001 of 1)",
    ),
    "zero quaternion": ("0 0 0 0 0 0 0 0", "fields qx qy qz qw: quaternion norm 0, not a rotation"),
}


#: case -> (file name, its head, reader, error type, the bad line, the message after ``FILE:3: ``)
VALUE_CASES = {
    **{
        f"csv {case}": (
            "c.csv",
            f"robot_a,t_a,robot_b,t_b,x,y,z,qx,qy,qz,qw,score\n{_csv()}",
            read_closures,
            ConfigError,
            *v,
        )
        for case, v in CSV_VALUES.items()
    },
    **{
        f"tum {case}": ("a.tum", "# t x y z qx qy qz qw\n-1 0 0 0 0 0 0 1", read_tum, StorageError, *v)
        for case, v in TUM_VALUES.items()
    },
    "list huge stamp": (
        "rgb.txt",
        "# timestamp filename\n0.1 rgb/0.png",
        read_list,
        StorageError,
        "1e300 rgb/1.png",
        "field timestamp: 1e+300 s is out of range (allowed: a magnitude of at most 1e+11 s)",
    ),
    "list inf stamp": (
        "rgb.txt",
        "0.1 rgb/0.png\n0.2 rgb/1.png",
        read_list,
        StorageError,
        "inf rgb/2.png",
        "field timestamp: inf is not a finite number",
    ),
}


@pytest.mark.parametrize("case", sorted(VALUE_CASES))
def test_a_value_out_of_range_names_file_line_and_field(tmp_path: Path, case: str) -> None:
    name, head, reader, error, line, message = VALUE_CASES[case]
    path = tmp_path / name
    path.write_text(f"{head}\n{line}\n", encoding="utf-8")
    with pytest.raises(error) as err:
        reader(path)
    assert str(err.value).startswith(f"{path}:3: {message}")


def test_a_tum_quaternion_rounded_to_four_decimals_is_read_as_a_rotation(tmp_path: Path) -> None:
    """The TUM benchmark's own files round quaternions to 4 decimals (norm off by up to 1e-4)."""
    path = tmp_path / "a.tum"
    path.write_text("0 1 2 3 0.6574 0.6126 -0.2949 -0.3248\n", encoding="utf-8")
    R = read_tum(path).T[0, :3, :3]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)


def test_a_reference_trajectory_csv_value_out_of_range(tmp_path: Path) -> None:
    path = tmp_path / "a.csv"
    path.write_text("#timestamp_kf,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1e308,0,0,0,1,0,0,0\n", encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        read_pose_csv(path)
    assert str(err.value) == (
        f"{path}:3: field timestamp_kf: 1e+308 ns is out of range (allowed: a magnitude of at most 1e+20 ns)"
    )
