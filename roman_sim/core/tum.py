"""TUM trajectory files (``timestamp tx ty tz qx qy qz qw`` per line), readable by evo.

Every number read from a file is checked where it is read, with the file and line: finite,
a time within ``MAX_TIME_S`` and a coordinate within ``MAX_COORD_M`` in magnitude (beyond
them a product of poses overflows or keeps no digit of a robot's motion, and no map spans
them), and a TUM quaternion of norm within ``TUM_QUAT_TOL`` of 1 (its decimals are rounded;
farther it is no rotation, and it is never normalised into one). ``field_problem`` and
``pose_problem`` say what is wrong with a value, for every reader of poses.
"""

from __future__ import annotations

import gzip
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import EvaluationError, StorageError
from roman_sim.core.trajectory import Trajectory

#: Largest magnitude of a coordinate read from a file (m).
MAX_COORD_M = 1e9
#: Largest magnitude of a time read from a file (s): 1e11 s is 3000 years (a larger stamp is
#: not in seconds: nanoseconds, often).
MAX_TIME_S = 1e11
#: Largest deviation of a TUM quaternion's norm from 1.
TUM_QUAT_TOL = 1e-3
#: The fields of a TUM line, in order.
TUM_FIELDS = ("timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw")


def field_problem(name: str, value: float, limit: float | None = None, unit: str = "") -> str | None:
    """What is wrong with one number read from a file (None: nothing): not finite, or beyond ``limit``
    in magnitude (``unit`` names the limit's unit in the message)."""
    if limit is None:
        if math.isfinite(value):
            return None
    elif -limit <= value <= limit:  # False for NaN
        return None
    if not math.isfinite(value):
        return f"field {name}: {value} is not a finite number"
    u = f" {unit}" if unit else ""
    return f"field {name}: {value:g}{u} is out of range (allowed: a magnitude of at most {limit:g}{u})"


def time_problem(name: str, value: float) -> str | None:
    """What is wrong with a time in seconds read from a file (None: nothing): ``field_problem`` within
    ``MAX_TIME_S``; a finite value beyond it is named as what it most likely is, nanoseconds."""
    bad = field_problem(name, value, MAX_TIME_S, "s")
    if bad is None or not math.isfinite(value):
        return bad
    return f"{bad}; it looks like nanoseconds (times here are seconds)"


def pose_problem(names: Sequence[str], values: Sequence[float]) -> str | None:
    """What is wrong with a pose read from a file, ``x y z qx qy qz qw`` (None: nothing): every value
    finite, the position within ``MAX_COORD_M``. ``names``: the seven fields' names in the file."""
    x, y, z = values[0], values[1], values[2]
    lim = MAX_COORD_M
    if -lim <= x <= lim and -lim <= y <= lim and -lim <= z <= lim and all(map(math.isfinite, values[3:7])):
        return None
    for i in range(7):
        bad = field_problem(names[i], values[i], MAX_COORD_M if i < 3 else None, "m" if i < 3 else "")
        if bad is not None:
            return bad
    return None


def format_tum(traj: Trajectory) -> str:
    """TUM text of a trajectory."""
    if len(traj) == 0:
        return ""
    q = Rotation.from_matrix(traj.T[:, :3, :3]).as_quat()  # x, y, z, w
    rows = np.column_stack([traj.t, traj.positions, q])
    return "".join(" ".join(f"{v:.9f}" for v in row) + "\n" for row in rows)


def write_tum(path: str | Path, traj: Trajectory) -> None:
    """Atomically write a TUM file."""
    write_text(path, format_tum(traj))


def read_tum(path: str | Path) -> Trajectory:
    """Read a TUM file (gzip-compressed when the name ends in ``.gz``) into a ``Trajectory``.

    Raises:
        StorageError: missing file, a malformed line (with its number), or an invalid trajectory.
    """
    path = Path(path)
    if not path.is_file():
        raise StorageError(f"{path}: TUM file not found")
    try:
        raw = path.read_bytes()
        text = (gzip.decompress(raw) if path.suffix == ".gz" else raw).decode("utf-8")
    except (OSError, UnicodeDecodeError, EOFError, gzip.BadGzipFile) as err:
        raise StorageError(f"{path}: unreadable TUM file ({type(err).__name__})") from None
    return parse_tum(text, str(path))


def parse_tum(text: str, source: str = "TUM") -> Trajectory:
    """A ``Trajectory`` from TUM text. Comment lines (#) are skipped; ``source`` names it in errors.

    Raises:
        StorageError: ``SOURCE:LINE: ...`` for a line that is not 8 numbers, a value that is not
            finite or out of range (``field_problem``), or a quaternion that is not of unit norm
            within ``TUM_QUAT_TOL``; ``SOURCE: ...`` for an invalid trajectory (time going back).
    """
    path = source
    rows = []
    for n, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise StorageError(f"{path}:{n}: not a number in TUM line") from None
        if len(vals) != 8:
            raise StorageError(f"{path}:{n}: expected 8 values per TUM line, got {len(vals)}")
        bad = time_problem(TUM_FIELDS[0], vals[0]) or pose_problem(TUM_FIELDS[1:], vals[1:])
        if bad is None:
            norm = math.sqrt(sum(q * q for q in vals[4:8]))
            if not abs(norm - 1.0) <= TUM_QUAT_TOL:
                bad = (
                    f"fields qx qy qz qw: quaternion norm {norm:.6g}, not a rotation (allowed: a norm within "
                    f"{TUM_QUAT_TOL:g} of 1)"
                )
        if bad is not None:
            raise StorageError(f"{path}:{n}: {bad}")
        rows.append(vals)
    if not rows:
        return Trajectory.empty()
    arr = np.asarray(rows)
    T = np.tile(np.eye(4), (len(arr), 1, 1))
    T[:, :3, :3] = Rotation.from_quat(arr[:, 4:8]).as_matrix()
    T[:, :3, 3] = arr[:, 1:4]
    try:
        return Trajectory(arr[:, 0], T)
    except EvaluationError as err:
        raise StorageError(f"{path}: {err}") from None
