"""The object table of an exported scenario: ids, families and oriented boxes, as JSON and CSV.

Every pose is in the world frame of the sequences' ground truth (``groundtruth.txt``, the
``world`` tf frame). ``mask_value`` is the value of the object's pixels in the instance
mask PNGs (``id + 1``). The box is the object's oriented bounding box: centre, rotation
(quaternion x, y, z, w; columns of ``R`` are the box axes) and full extents along those axes.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Mapping
from pathlib import Path
from typing import TypedDict

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from roman_sim.core.atomic import write_json, write_text
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSONLike
from roman_sim.world.truth import WorldTruth

OBJECTS_JSON = "objects.json"
OBJECTS_CSV = "objects.csv"
FORMAT = "roman_sim.objects"
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


class ObjectBox(TypedDict):
    """An object's oriented bounding box: centre, rotation (quaternion and matrix), full extents."""

    center: list[float]
    quaternion_xyzw: list[float]
    R: list[list[float]]
    extents: list[float]


class ObjectRow(TypedDict):
    """One object's record of ``objects.json``."""

    id: int
    mask_value: int
    family: str
    box: ObjectBox
    T_world_obj: list[list[float]]
    volume_m3: float
    centroid: list[float]


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
        rows.append(
            {
                "id": int(o.id),
                "mask_value": int(o.id) + 1,
                "family": o.family,
                "box": {
                    "center": _r(box[:3, 3]),
                    "quaternion_xyzw": _r(Rotation.from_matrix(box[:3, :3]).as_quat()),
                    "R": _r2(box[:3, :3]),
                    "extents": _r(o.obb_extents),
                },
                "T_world_obj": _r2(o.T_world_obj),
                "volume_m3": round(float(o.volume), 9),
                "centroid": _r(o.centroid),
            }
        )
    return rows


def _csv_text(rows: list[ObjectRow]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in rows:
        b = r["box"]
        w.writerow(
            [
                r["id"],
                r["mask_value"],
                r["family"],
                *b["center"],
                *b["quaternion_xyzw"],
                *b["extents"],
                r["volume_m3"],
                *r["centroid"],
            ]
        )
    return buf.getvalue()


def write_object_table(
    out_dir: str | Path, truth: WorldTruth, extra: Mapping[str, JSONLike] | None = None
) -> list[Path]:
    """Write ``objects.json`` and ``objects.csv`` atomically into ``out_dir``; returns both paths."""
    out = Path(out_dir)
    rows = object_rows(truth)
    doc = {
        "format": FORMAT,
        "version": 1,
        "frame": "world",
        "mask_value": "id + 1 (0 = background)",
        "objects": rows,
        **(extra or {}),
    }
    write_json(out / OBJECTS_JSON, doc)
    write_text(out / OBJECTS_CSV, _csv_text(rows))
    return [out / OBJECTS_JSON, out / OBJECTS_CSV]


def read_object_table(path: str | Path) -> list[ObjectRow]:
    """The object records of an ``objects.json`` (a file or the folder holding it)."""
    p = Path(path)
    if p.is_dir():
        p = p / OBJECTS_JSON
    if not p.is_file():
        raise StorageError(f"{p}: object table not found")
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise StorageError(f"{p}: unreadable object table ({err})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT or not isinstance(doc.get("objects"), list):
        raise StorageError(f"{p}: not a roman_sim object table")
    return list(doc["objects"])
