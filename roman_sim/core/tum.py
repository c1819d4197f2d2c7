"""TUM trajectory files (``timestamp tx ty tz qx qy qz qw`` per line), readable by evo."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import EvaluationError, StorageError
from roman_sim.core.trajectory import Trajectory


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
    """Read a TUM file into a ``Trajectory``. Comment lines (#) are skipped.

    Raises:
        StorageError: missing file, a malformed line (with its number), or an invalid trajectory.
    """
    path = Path(path)
    if not path.is_file():
        raise StorageError(f"{path}: TUM file not found")
    rows = []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
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
        rows.append(vals)
    if not rows:
        return Trajectory.empty()
    arr = np.asarray(rows)
    if not np.all(np.isfinite(arr)) or np.any(np.linalg.norm(arr[:, 4:8], axis=1) == 0):
        raise StorageError(f"{path}: non-finite value or zero quaternion in a TUM line")
    T = np.tile(np.eye(4), (len(arr), 1, 1))
    T[:, :3, :3] = Rotation.from_quat(arr[:, 4:8]).as_matrix()
    T[:, :3, 3] = arr[:, 1:4]
    try:
        return Trajectory(arr[:, 0], T)
    except EvaluationError as err:
        raise StorageError(f"{path}: {err}") from None
