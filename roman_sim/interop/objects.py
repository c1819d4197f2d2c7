"""The object table of an exported scenario: ids, families and oriented boxes, as JSON and CSV.

Every pose is in the world frame of the sequences' ground truth (``groundtruth.txt``, the
``world`` tf frame). ``mask_value`` is the value of the object's pixels in the instance
mask PNGs (``id + 1``). The box is the object's oriented bounding box: centre, rotation
(quaternion x, y, z, w; columns of ``R`` are the box axes) and full extents along those axes.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_text
from roman_sim.core.errors import StorageError
from roman_sim.core.records import OMIT_NONE, read_record, write_record
from roman_sim.frontend.appearance import LooksRecord
from roman_sim.world.truth import WorldTruth

OBJECTS_JSON = "objects.json"
OBJECTS_CSV = "objects.csv"
FORMAT: Literal["roman_sim.objects"] = "roman_sim.objects"
CSV_COLUMNS = (
    "id",
    "mask_value",
    "family",
    "center_x",
    "center_y",
    "center_z",
    "qx",
    "qy",
    "qz",
    "qw",
    "extent_x",
    "extent_y",
    "extent_z",
    "volume_m3",
    "centroid_x",
    "centroid_y",
    "centroid_z",
)


@dataclass(frozen=True)
class ObjectBox:
    """An object's oriented bounding box: centre, rotation (quaternion and matrix), full extents."""

    center: list[float]
    quaternion_xyzw: list[float]
    R: list[list[float]]
    extents: list[float]


@dataclass(frozen=True)
class ObjectRow:
    """One object's record of ``objects.json``."""

    id: int
    mask_value: int
    family: str
    box: ObjectBox
    T_world_obj: list[list[float]]
    volume_m3: float
    centroid: list[float]


@dataclass(frozen=True)
class TableLooks:
    """The looks an object table carries: the world's, and each robot's light (sun azimuth,
    elevation and share) where it renders under its own."""

    looks: LooksRecord
    lights: dict[str, tuple[float, float, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class ObjectTable:
    """What ``objects.json`` holds: the objects in the world frame and, for an export, its scenario,
    seed and looks (``TableLooks``'s fields, at the top level)."""

    format: Literal["roman_sim.objects"]
    version: int
    frame: str
    mask_value: str
    objects: list[ObjectRow]
    scenario: str | None = field(default=None, metadata=OMIT_NONE)
    seed: int | None = field(default=None, metadata=OMIT_NONE)
    looks: LooksRecord | None = field(default=None, metadata=OMIT_NONE)
    lights: dict[str, tuple[float, float, float]] | None = field(default=None, metadata=OMIT_NONE)


def _r(a: ArrayLike) -> list[float]:
    """A vector rounded to 9 decimals, as a list."""
    rounded: list[float] = np.round(np.asarray(a, dtype=np.float64), 9).tolist()
    return rounded


def _r2(a: ArrayLike) -> list[list[float]]:
    """A matrix rounded to 9 decimals, as nested lists."""
    rounded: list[list[float]] = np.round(np.asarray(a, dtype=np.float64), 9).tolist()
    return rounded


def object_rows(truth: WorldTruth) -> list[ObjectRow]:
    """One JSON-friendly record per object, ordered by id."""
    rows: list[ObjectRow] = []
    for o in sorted(truth.objects, key=lambda o: o.id):
        box = np.asarray(o.obb_T_world, dtype=np.float64)
        quat = _r(Rotation.from_matrix(box[:3, :3]).as_quat())
        obb = ObjectBox(_r(box[:3, 3]), quat, _r2(box[:3, :3]), _r(o.obb_extents))
        volume = round(float(o.volume), 9)
        rows.append(ObjectRow(int(o.id), int(o.id) + 1, o.family, obb, _r2(o.T_world_obj), volume, _r(o.centroid)))
    return rows


def _csv_text(rows: list[ObjectRow]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in rows:
        b = r.box
        w.writerow([r.id, r.mask_value, r.family, *b.center, *b.quaternion_xyzw, *b.extents, r.volume_m3, *r.centroid])
    return buf.getvalue()


def write_object_table(
    out_dir: str | Path,
    truth: WorldTruth,
    scenario: str | None = None,
    seed: int | None = None,
    looks: TableLooks | None = None,
) -> list[Path]:
    """Write ``objects.json`` and ``objects.csv`` atomically into ``out_dir``; returns both paths."""
    out = Path(out_dir)
    rows = object_rows(truth)
    own = (None, None) if looks is None else (looks.looks, looks.lights)
    table = ObjectTable(FORMAT, 1, "world", "id + 1 (0 = background)", rows, scenario, seed, *own)
    write_record(out / OBJECTS_JSON, table)
    write_text(out / OBJECTS_CSV, _csv_text(rows))
    return [out / OBJECTS_JSON, out / OBJECTS_CSV]


def read_objects_json(path: str | Path) -> ObjectTable:
    """The ``objects.json`` at ``path`` (a file or the folder holding it); StorageError when absent,
    RecordError naming the file and the field when it is not an object table."""
    p = Path(path)
    if p.is_dir():
        p = p / OBJECTS_JSON
    if not p.is_file():
        raise StorageError(f"{p}: object table not found")
    return read_record(p, ObjectTable)


def read_object_table(path: str | Path) -> list[ObjectRow]:
    """The object records of an ``objects.json`` (a file or the folder holding it)."""
    return read_objects_json(path).objects
