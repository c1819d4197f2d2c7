"""TUM trajectory files (``timestamp tx ty tz qx qy qz qw`` per line), readable by evo."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import StorageError


def format_tum(t: ArrayLike, T: ArrayLike) -> str:
    """TUM text for times (N,) and poses (N, 4, 4)."""
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    T = np.asarray(T, dtype=np.float64).reshape(-1, 4, 4)
    if len(t) != len(T):
        raise StorageError(f"TUM: {len(t)} timestamps but {len(T)} poses")
    if len(T) == 0:
        return ""
    q = Rotation.from_matrix(T[:, :3, :3]).as_quat()  # x, y, z, w
    rows = np.column_stack([t, T[:, :3, 3], q])
    return "".join(" ".join(f"{v:.9f}" for v in row) + "\n" for row in rows)


def write_tum(path: str | Path, t: ArrayLike, T: ArrayLike) -> None:
    """Atomically write a TUM file."""
    write_text(path, format_tum(t, T))


def read_tum(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read a TUM file; returns times (N,) and poses (N, 4, 4). Comment lines (#) are skipped."""
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
        return np.zeros(0), np.zeros((0, 4, 4))
    arr = np.asarray(rows)
    T = np.tile(np.eye(4), (len(arr), 1, 1))
    T[:, :3, :3] = Rotation.from_quat(arr[:, 4:8]).as_matrix()
    T[:, :3, 3] = arr[:, 1:4]
    return arr[:, 0], T
