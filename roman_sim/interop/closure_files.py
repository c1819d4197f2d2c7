"""Any system's closure file: which format it is in, and its closures.

=================  ==================================================================  ================================
format             what it is                                                          read by
=================  ==================================================================  ================================
``csv``            this testbed's CSV (``robot_a,t_a,robot_b,t_b,x,y,z,qx,qy,qz,qw``)  ``closures.read_csv_closures``
``g2o``            g2o with gtsam Symbol keys and a timestamps file (the reference's   ``closures.read_g2o_closures``
                   fused ``odom_and_lc.g2o``, Kimera-RPGO)
``roman_align``    the reference's per-pair ``align.g2o`` (keys ``a12 b34``) or its    ``roman_align.read_align``
                   ``align`` folder
``kimera_multi``   Kimera-Multi's ``loop_closures.csv`` or a folder of them            ``kimera.read_kimera``
=================  ==================================================================  ================================

The format is told by the file, not by a flag: a ``.csv`` file by its first line (Kimera-Multi's
header, else this testbed's CSV, whose header is optional; any other header is an error), a
``.g2o`` file by the keys of its first edge (whole numbers, or a letter and an index), a folder
by what it holds. Anything else is an error naming what is allowed.
"""

from __future__ import annotations

import csv
from collections.abc import Iterable, Sequence
from pathlib import Path

from roman_sim.core.errors import ConfigError
from roman_sim.interop.closures import (
    CSV_FIELDS,
    ClosureSet,
    QuaternionOrder,
    first_edge_keys,
    read_closures,
    read_stream,
)
from roman_sim.interop.kimera import LC_CSV, LC_FIELDS, read_kimera
from roman_sim.interop.roman_align import ALIGN_G2O, read_align

FORMATS = ("csv", "g2o", "roman_align", "kimera_multi")
ALLOWED = (
    "a .csv file (this testbed's closures or Kimera-Multi's loop_closures.csv), a .g2o file (gtsam Symbol keys, or "
    "the reference ROMAN's per-pair align.g2o), the reference's align folder, or a folder of Kimera-Multi's logs"
)


def _first_data_row(lines: Iterable[str], p: Path) -> tuple[int, list[str]]:
    for n, row in enumerate(csv.reader(lines), start=1):
        cells = [c.strip() for c in row]
        if cells and any(cells) and not cells[0].startswith("#"):
            return n, cells
    return 0, []


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def closure_format(path: str | Path) -> str:
    """The format of a closure file or folder (module docstring); ConfigError when it is none of them."""
    p = Path(path)
    if p.is_dir():
        if any(p.glob(f"*/{ALIGN_G2O}")) or (p / ALIGN_G2O).is_file():
            return "roman_align"
        if any(p.rglob(LC_CSV)):
            return "kimera_multi"
        raise ConfigError(f"--closures {p}: a folder without closures (allowed: {ALLOWED})")
    if not p.is_file():
        raise ConfigError(f"--closures {p}: no such file")
    if p.suffix.lower() == ".csv":
        n, row = read_stream(p, "closure file", _first_data_row)
        if row[:4] == LC_FIELDS[:4]:
            return "kimera_multi"
        if row and row[0] != CSV_FIELDS[0] and len(row) > 1 and not _is_number(row[1]):
            raise ConfigError(
                f"{p}:{n}: unknown CSV header {','.join(row)!r} (allowed: {','.join(CSV_FIELDS)}, or Kimera-Multi's "
                f"{','.join(LC_FIELDS)})"
            )
        return "csv"
    if p.suffix.lower() == ".g2o":
        keys = first_edge_keys(p)
        return "roman_align" if keys is not None and not keys[0].isdigit() else "g2o"
    raise ConfigError(f"--closures {p}: unknown file type {p.suffix or '(none)'!r} (allowed: {ALLOWED})")


def read_closure_file(
    path: str | Path,
    robots: Sequence[str],
    times: str | Path | None = None,
    quaternion_order: QuaternionOrder = "xyzw",
) -> tuple[ClosureSet, str]:
    """The closures of a file or folder in any format (module docstring), and the format's name.

    Args:
        path: the closure file or folder.
        robots: the robot order (a g2o file's Symbol characters, the reference's ``runs``,
            Kimera-Multi's robot indices).
        times: a g2o file's timestamps file; the reference's dense timestamps file (instead of
            each ``align.json``); Kimera-Multi's ``odometry_poses.csv`` file or folder.
        quaternion_order: the order of the file's quaternion numbers.
    """
    fmt = closure_format(path)
    if fmt == "roman_align":
        return read_align(path, robots, times, quaternion_order), fmt
    if fmt == "kimera_multi":
        return read_kimera(path, robots, times, quaternion_order), fmt
    return read_closures(path, times, robots, quaternion_order=quaternion_order), fmt
