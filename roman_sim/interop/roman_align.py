"""The reference ROMAN's per-pair loop closures (``align/<run_i>_<run_j>/align.g2o``), read and written.

The reference demo (``mit-acl/roman``, ``demo/demo.py``) aligns every pair of robots
``(i, j)``, ``i <= j`` in its ``runs`` order, and ``save_submap_align_results``
(``roman/align/results.py``) writes into ``align/<run_i>_<run_j>/``:

- ``align.g2o``: for every pair of submaps with at least ``-n`` associations (its
  ``--num-req-assoc``, 4 by default), a line ``# LC: <associations>`` and
  ``EDGE_SE3:QUAT a<k> b<l> tx ty tz qx qy qz qw`` followed by the 21 upper-triangle entries
  of the information matrix. The pose is ``T_pi_pj``: robot j's body at its submap's centre
  time in robot i's body frame at its submap's (the edge ``roman_sim.interop.closures``
  reads). The key's letter is the robot of the pair (``a``: ``run_i``, ``b``: ``run_j``, both
  the same robot in ``<run>_<run>``); its index is **not** the submap's index: it is the
  index of the submap's centre pose in the robot's mapped trajectory
  (``pose_data.idx(submap.time)`` over the map's ``times``), the vertex index of the
  reference's dense odometry g2o, whose times ``offline_rpgo/dense/odom_all.time.txt`` lists
  (``robot_id pose_index time_ns``, robot ids in ``runs`` order). The reference's mapper
  poses are ``t0 + k * dt`` (``np.arange``), and the ROMAN-ready export sets ``dt`` to the
  frame interval, so pose ``k`` is the exported frame ``k`` (its float steps near 1.7e9 s
  drift by microseconds, far within the match tolerance). Intra-robot files hold every
  ordered pair of submaps at least 50 s apart, so each pair twice, once each way.
- ``align.json``: the same closures in the same order, each with the two robots'
  ``names``, their centre times as ``seconds`` and ``nanoseconds`` (the bag's stamps) and
  the pose (``translation``, ``rotation`` with ``rotation_convention: xyzw``).

``read_align`` reads a pair's ``align.g2o`` or a whole ``align`` folder (every
``<run_i>_<run_j>/align.g2o`` in it, in name order, their lines numbered as one text: see
``ClosureSet.files``): the ``# LC:`` counts are the closures' scores, so they draw a
precision-recall curve (above the demo's ``-n``). Each edge's robots and times come from
``align.json`` beside it, or, with ``times``, from the timestamps file by pose index (the
pair's robots then from the folder name, ``<run_i>_<run_j>``). The closures are then matched
to this testbed's submaps by time, like every closure file: roman_sim keeps empty submaps in
its numbering where the reference drops them from its list, so no index is shared between
the two, and the times are. ``write_align`` writes the same layout from any closures.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import inv_T
from roman_sim.core.records import RecordError, read_json
from roman_sim.interop.closures import (
    EDGE,
    Closure,
    ClosureSet,
    KeyframeTimes,
    QuaternionOrder,
    line_error,
    np_poses,
    read_stream,
    read_times_file,
    scan_g2o,
    xyz_quat,
)
from roman_sim.interop.stamps import nearest_frames

ALIGN_G2O, ALIGN_JSON = "align.g2o", "align.json"
#: The reference's default closure information: translation std 0.5 m, rotation std 0.5 deg.
INFO_DIAG = (4.0, 4.0, 4.0, 1.0 / np.deg2rad(0.5) ** 2, 1.0 / np.deg2rad(0.5) ** 2, 1.0 / np.deg2rad(0.5) ** 2)
_SYMBOL_INDEX = (1 << 56) - 1


def align_files(path: Path) -> list[Path]:
    """The per-pair files of ``path``: itself (a file), or every ``<run_i>_<run_j>/align.g2o`` of a folder."""
    if not path.is_dir():
        return [path]
    files = sorted(path.glob(f"*/{ALIGN_G2O}"))
    if not files and (path / ALIGN_G2O).is_file():
        files = [path / ALIGN_G2O]
    if not files:
        raise ConfigError(f"--closures {path}: no <robot>_<robot>/{ALIGN_G2O} in the folder (the reference's align)")
    return files


def _pair_from_folder(path: Path, robots: Sequence[str]) -> tuple[str, str]:
    """The pair ``(run_i, run_j)`` its folder's name ``<run_i>_<run_j>`` names."""
    name = path.parent.name
    for r in robots:
        if name.startswith(f"{r}_") and name[len(r) + 1 :] in robots:
            return r, name[len(r) + 1 :]
    raise ConfigError(
        f"{path}: its folder {name!r} names no pair of robots <run_i>_<run_j> (robots: {', '.join(robots)}); the "
        f"pair is read from {ALIGN_JSON} beside it, or from the folder's name"
    )


def _json_entries(path: Path, n: int) -> tuple[tuple[str, str], NDArray[np.float64], NDArray[np.float64]]:
    """The pair's robots and each closure's two times (s, as stamped) from ``align.json``."""
    where = f"{path}: a list of {n} closures, each with names [run_i, run_j], seconds [s, s], nanoseconds [ns, ns]"
    try:
        doc = read_json(path)  # ROMAN's own file: its entries are checked here, other keys left alone
    except RecordError as err:
        raise ConfigError(str(err)) from None
    if not isinstance(doc, list) or len(doc) != n:
        got = f"{len(doc)} entries" if isinstance(doc, list) else type(doc).__name__
        raise ConfigError(f"{where} (one per edge of {ALIGN_G2O}); got {got}")
    names, t = set(), np.zeros((n, 2))
    for i, e in enumerate(doc):
        ok = isinstance(e, dict) and all(
            isinstance(e.get(k), list) and len(e[k]) == 2 for k in ("names", "seconds", "nanoseconds")
        )
        ints = ok and all(type(v) is int and v >= 0 for k in ("seconds", "nanoseconds") for v in e[k])
        if not ints or not all(isinstance(r, str) for r in e["names"]) or max(e["nanoseconds"]) >= 10**9:
            raise ConfigError(f"{where}; entry {i} is not")
        names.add(tuple(e["names"]))
        t[i] = [s + ns / 1e9 for s, ns in zip(e["seconds"], e["nanoseconds"])]
    if len(names) > 1:
        raise ConfigError(f"{where}; its entries name several pairs: {sorted(names)}")
    pair = next(iter(names)) if names else ("", "")
    return (pair[0], pair[1]), t[:, 0], t[:, 1]


def _read_one(
    path: Path, robots: Sequence[str], times: KeyframeTimes | None, order: QuaternionOrder
) -> tuple[ClosureSet, int]:
    """One ``align.g2o``: its closures and its number of lines."""
    keys, poses, scores, where = read_stream(path, "closure file", scan_g2o, True)
    k = np.frombuffer(keys, dtype=np.uint64).reshape(-1, 2)
    line = np.frombuffer(where, dtype=np.int64).copy()
    letter = (k >> np.uint64(56)).astype(np.int64) - ord("a")
    idx = (k & np.uint64(_SYMBOL_INDEX)).astype(np.int64)
    wrong = letter != np.arange(2)[None, :]
    if wrong.any():
        row, end = np.argwhere(wrong)[0]
        got = chr(ord("a") + int(letter[row, end])) + str(int(idx[row, end]))
        raise line_error(
            path,
            int(line[row]),
            f"key {got}: the {'first' if end == 0 else 'second'} key is "
            f"{'a' if end == 0 else 'b'}<index> (the pair's {'first' if end == 0 else 'second'} robot)",
        )
    if times is None:
        if not (path.parent / ALIGN_JSON).is_file():
            raise ConfigError(
                f"{path}: no {ALIGN_JSON} beside it (the reference writes both) and no timestamps file: give the "
                "reference's offline_rpgo/dense/odom_all.time.txt with --times"
            )
        pair, t_a, t_b = _json_entries(path.parent / ALIGN_JSON, len(line))
        if len(line) and not all(r in robots for r in pair):
            raise ConfigError(f"{path.parent / ALIGN_JSON}: robots {pair}: allowed: {', '.join(robots)}")
    else:
        pair = _pair_from_folder(path, robots)
        ids = np.asarray([robots.index(r) for r in pair], dtype=np.uint64)
        t, found = times.lookup(((np.uint64(ord("a")) + ids[None, :]) << np.uint64(56)) | idx.astype(np.uint64))
        if not found.all():
            row, end = np.argwhere(~found)[0]
            raise line_error(
                path,
                int(line[row]),
                f"pose {int(idx[row, end])} of robot {pair[end]} (id {robots.index(pair[end])}) has no time in the "
                "timestamps file",
            )
        t_a, t_b = t[:, 0].copy(), t[:, 1].copy()
    names = tuple(dict.fromkeys(pair))
    codes = np.asarray([names.index(r) for r in pair], dtype=np.int64)
    with path.open("rb") as fh:
        n_lines = sum(1 for _ in fh)
    cs = ClosureSet(
        names,
        np.full(len(line), codes[0]),
        t_a,
        np.full(len(line), codes[1]),
        t_b,
        np_poses(np.frombuffer(poses, dtype=np.float64).reshape(-1, 7), order),
        np.frombuffer(scores, dtype=np.int64).copy(),
        line,
    )
    return cs, n_lines


def read_align(
    path: str | Path, robots: Sequence[str], times: str | Path | None = None, quaternion_order: QuaternionOrder = "xyzw"
) -> ClosureSet:
    """The closures of a reference ``align.g2o`` or ``align`` folder (module docstring).

    Args:
        path: an ``align.g2o`` file, or the ``align`` folder of its pairs.
        robots: the robots in the reference's ``runs`` order (the timestamps file's robot ids).
        times: the dense timestamps file; None: each file's ``align.json``.
        quaternion_order: the order of the edges' quaternion numbers.
    """
    p = Path(path)
    kt = read_times_file(times) if times is not None else None
    files = align_files(p)
    parts = [(*_read_one(f, robots, kt, quaternion_order), f) for f in files]
    if len(parts) == 1:
        return parts[0][0]
    return ClosureSet.concat([(cs, str(f.relative_to(p)), n) for cs, n, f in parts])


def _info_text() -> str:
    info = np.diag(np.asarray(INFO_DIAG))
    return " ".join(repr(float(info[i, j])) for i in range(6) for j in range(i, 6))


def write_align(
    out: str | Path,
    closures: Sequence[Closure],
    frames: dict[str, NDArray[np.float64]],
    robots: Sequence[str],
    epoch_ns: int,
    min_score: int | None = None,
) -> list[Path]:
    """Write closures in the reference's per-pair layout (module docstring); the files written.

    ``out/align/<run_i>_<run_j>/align.g2o`` and ``align.json`` for every pair ``i <= j`` of
    ``robots`` (the ``runs`` order; an intra-robot closure once each way, as the reference
    writes them), and ``out/offline_rpgo/dense/<run>.time.txt`` and ``odom_all.time.txt``:
    one pose per frame of ``frames`` (seconds since the start; the pose index is the frame
    index), stamped ``epoch_ns`` plus the time. Closures below ``min_score`` are left out (the
    demo's ``-n``); every closure needs a score.
    """
    root, info = Path(out), _info_text()
    stamp = {r: [epoch_ns + round(float(t) * 1e9) for t in frames[r]] for r in robots}
    edges: dict[tuple[str, str], list[Closure]] = {(a, b): [] for i, a in enumerate(robots) for b in robots[i:]}
    for c in closures:
        if c.score is None:
            raise ConfigError(f"closure {c.robot_a} {c.t_a} s | {c.robot_b} {c.t_b} s: the per-pair file needs a score")
        if min_score is not None and c.score < min_score:
            continue
        key, flip = (c.robot_a, c.robot_b), Closure(c.robot_b, c.t_b, c.robot_a, c.t_a, inv_T(c.T_pa_pb), c.score)
        if c.robot_a == c.robot_b:
            edges[key] += [c, flip]
        elif key in edges:
            edges[key].append(c)
        else:
            edges[(c.robot_b, c.robot_a)].append(flip)
    written = []
    for (ra, rb), rows in edges.items():
        lines, entries = [], []
        for c in sorted(rows, key=lambda c: (c.t_a, c.t_b)):
            ia, ib = (int(nearest_frames(frames[r], np.asarray([t]))[0]) for r, t in ((ra, c.t_a), (rb, c.t_b)))
            pose = xyz_quat(c.T_pa_pb)
            lines.append(f"# LC: {int(c.score or 0)}\n")
            lines.append(
                f"{EDGE} a{ia} b{ib} \t{' '.join(map(repr, pose[:3]))} \t{' '.join(map(repr, pose[3:]))} \t{info}\n"
            )
            ns = (stamp[ra][ia], stamp[rb][ib])
            entries.append(_json_entry(ns, (ra, rb), pose))
        folder = root / "align" / f"{ra}_{rb}"
        folder.mkdir(parents=True, exist_ok=True)
        write_text(folder / ALIGN_G2O, "".join(lines))
        write_text(folder / ALIGN_JSON, json.dumps(entries, indent=4) + "\n")
        written += [folder / ALIGN_G2O, folder / ALIGN_JSON]
    dense = root / "offline_rpgo" / "dense"
    dense.mkdir(parents=True, exist_ok=True)
    every = []
    for i, r in enumerate(robots):
        text = "".join(f"{i} {k} {ns} xxx\n" for k, ns in enumerate(stamp[r]))
        write_text(dense / f"{r}.time.txt", text)
        every.append(text)
        written.append(dense / f"{r}.time.txt")
    write_text(dense / "odom_all.time.txt", "".join(every))
    return [*written, dense / "odom_all.time.txt"]


def _json_entry(ns: tuple[int, int], names: tuple[str, str], pose: list[float]) -> dict[str, Any]:
    return {
        "seconds": [n // 10**9 for n in ns],
        "nanoseconds": [n % 10**9 for n in ns],
        "names": list(names),
        "translation": pose[:3],
        "rotation": pose[3:],
        "rotation_convention": "xyzw",
    }
