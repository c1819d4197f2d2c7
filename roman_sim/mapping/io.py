"""Versioned storage of ``SegmentMap`` and submap lists, and packet-size figures.

File format (both kinds): one ``.npz`` archive (``allow_pickle=False``) whose ``header``
entry is UTF-8 JSON (as uint8) with ``format`` (``roman_sim.segment_map`` or
``roman_sim.submaps``), ``version`` (``FORMAT_VERSION``) and per-item scalars; the numeric
arrays sit beside it:

- segment map: ``times`` (N,), ``T_odom_body``/``T_world_body`` (N,4,4), ``points`` (all
  segment points stacked) with ``offsets`` (n+1,), ``descriptor_sum`` (n,D) float64,
  ``has_descriptor`` (n,); the header lists id, times, sightings, status, truth counts.
- submaps: ``s<k>_<field>`` for every array field of submap k (descriptor dtype kept),
  optional ``s<k>_points`` + ``s<k>_offsets``, ``s<k>_kf_<field>`` (visual keyframes,
  version 2 on) and ``s<k>_truth_*``.

Round trips are exact. Version 1 files (no keyframes) are still read. Unknown formats,
versions and corrupt files raise ``StorageError``. A packet (``packet_bytes``) is what a
robot sends, compressed: the segment packet (public fields only, float32 geometry, float16
descriptors) and, counted apart, the keyframe packet (poses, BoW vectors, ORB descriptors,
keypoints and their 3D points).
"""

from __future__ import annotations

import io
import zipfile
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, TypeVar

import numpy as np

from roman_sim.core.atomic import write_arrays, write_npz
from roman_sim.core.errors import StorageError
from roman_sim.core.records import dumps_record, from_json, parse_json
from roman_sim.mapping.mapper import SegmentMap
from roman_sim.mapping.segment import Segment, Status
from roman_sim.mapping.types import KeyframeSet, Submap, SubmapTruth

FORMAT_VERSION = 2
#: Versions this reader accepts (1: submaps without keyframes).
READABLE_VERSIONS = (1, 2)
_SUBMAP_ARRAYS = ("T_odom_submap", "segment_ids", "centers", "volumes", "shape", "descriptors", "extents")


H = TypeVar("H")


@dataclass(frozen=True)
class SegmentRow:
    """One segment's scalars in a segment map's header (its arrays sit beside it)."""

    id: int
    first_seen: float
    last_seen: float
    num_sightings: int
    status: str
    truth_counts: list[tuple[int, int]]


@dataclass(frozen=True)
class SegmentMapHeader:
    """The header of a segment map file: format, version, robot and each segment's scalars."""

    format: Literal["roman_sim.segment_map"]
    version: int
    robot: str
    segments: list[SegmentRow]


@dataclass(frozen=True)
class SubmapRow:
    """One submap's scalars in a submap file's header, and which of its optional arrays are stored."""

    robot: str
    index: int
    t: float
    points: bool
    truth: bool
    keyframes: bool = False  # version 1 files have none


@dataclass(frozen=True)
class SubmapsHeader:
    """The header of a submap file: format, version and each submap's scalars."""

    format: Literal["roman_sim.submaps"]
    version: int
    submaps: list[SubmapRow]


@dataclass(frozen=True)
class KeyframesHeader:
    """The header of a keyframe file: format and version."""

    format: Literal["roman_sim.keyframes"]
    version: int


def _header(header: object) -> np.ndarray:
    return np.frombuffer(dumps_record(header).encode("utf-8"), dtype=np.uint8)


def _open(path: str | Path, fmt: str, cls: type[H]) -> tuple[H, dict[str, np.ndarray]]:
    path = Path(path)
    if not path.is_file():
        raise StorageError(f"{path}: file not found")
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        text = arrays.pop("header").tobytes()
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as err:
        raise StorageError(f"{path}: not a readable roman_sim file ({type(err).__name__})") from None
    header = parse_json(text, f"{path}: header")
    if not isinstance(header, dict) or header.get("format") != fmt:
        found = header.get("format") if isinstance(header, dict) else None
        raise StorageError(f"{path}: expected format {fmt!r}, found {found!r}")
    if header.get("version") not in READABLE_VERSIONS:
        raise StorageError(
            f"{path}: format version {header.get('version')!r} not supported "
            f"(this reader: {', '.join(map(str, READABLE_VERSIONS))})"
        )
    return from_json(cls, header, f"{path}: header"), arrays


def save_segment_map(path: str | Path, smap: SegmentMap) -> None:
    """Write ``smap`` atomically (see the module docstring for the layout)."""
    segs = smap.segments
    dim = next((len(s.descriptor_sum) for s in segs if s.descriptor_sum is not None), 0)
    dsum = np.zeros((len(segs), dim))
    for k, s in enumerate(segs):
        if s.descriptor_sum is not None:
            dsum[k] = s.descriptor_sum
    meta = [
        SegmentRow(
            s.id,
            s.first_seen,
            s.last_seen,
            s.num_sightings,
            s.status.value,
            sorted((int(k), int(v)) for k, v in s.truth_counts.items()),
        )
        for s in segs
    ]
    header = SegmentMapHeader("roman_sim.segment_map", FORMAT_VERSION, smap.robot, meta)
    truth = {} if smap.T_world_body is None else {"T_world_body": smap.T_world_body}
    write_arrays(
        path,
        {
            "header": _header(header),
            "times": smap.times,
            "T_odom_body": smap.T_odom_body,
            **truth,
            "points": np.concatenate([s.points for s in segs]) if segs else np.zeros((0, 3)),
            "offsets": np.cumsum([0] + [len(s.points) for s in segs]),
            "descriptor_sum": dsum,
            "has_descriptor": np.array([s.descriptor_sum is not None for s in segs], dtype=bool),
        },
    )


def load_segment_map(path: str | Path) -> SegmentMap:
    """Read a file written by ``save_segment_map``."""
    header, a = _open(path, "roman_sim.segment_map", SegmentMapHeader)
    try:
        segs = []
        for k, m in enumerate(header.segments):
            pts = a["points"][a["offsets"][k] : a["offsets"][k + 1]]
            segs.append(
                Segment(
                    id=m.id,
                    points=pts,
                    first_seen=float(m.first_seen),
                    last_seen=float(m.last_seen),
                    num_sightings=m.num_sightings,
                    descriptor_sum=a["descriptor_sum"][k].copy() if a["has_descriptor"][k] else None,
                    truth_counts=Counter(dict(m.truth_counts)),
                    status=Status(m.status),
                )
            )
        return SegmentMap(
            header.robot, segs, a["times"], a["T_odom_body"], a["T_world_body"] if "T_world_body" in a else None
        )
    except (KeyError, IndexError, TypeError, ValueError) as err:
        raise StorageError(f"{path}: inconsistent segment map ({type(err).__name__}: {err})") from None


def _submap_arrays(k: int, s: Submap) -> dict[str, np.ndarray]:
    out = {f"s{k}_{f}": np.asarray(getattr(s, f)) for f in _SUBMAP_ARRAYS}
    if s.points is not None:
        out[f"s{k}_points"] = np.concatenate(s.points) if s.points else np.zeros((0, 3))
        out[f"s{k}_offsets"] = np.cumsum([0] + [len(p) for p in s.points])
    if s.keyframes is not None:
        for f in KeyframeSet.FIELDS:
            out[f"s{k}_kf_{f}"] = np.asarray(getattr(s.keyframes, f))
    if s.truth is not None:
        out[f"s{k}_truth_T_world_submap"] = s.truth.T_world_submap
        out[f"s{k}_truth_object_ids"] = s.truth.object_ids
        out[f"s{k}_truth_purity"] = s.truth.purity
    return out


def save_submaps(path: str | Path, submaps: list[Submap]) -> None:
    """Write a list of submaps atomically (truth is kept when present)."""
    arrays: dict[str, np.ndarray] = {}
    meta = []
    for k, s in enumerate(submaps):
        arrays.update(_submap_arrays(k, s))
        meta.append(
            SubmapRow(s.robot, s.index, s.t, s.points is not None, s.truth is not None, s.keyframes is not None)
        )
    header = SubmapsHeader("roman_sim.submaps", FORMAT_VERSION, meta)
    write_arrays(path, {"header": _header(header), **arrays})


def load_submaps(path: str | Path) -> list[Submap]:
    """Read a file written by ``save_submaps``."""
    header, a = _open(path, "roman_sim.submaps", SubmapsHeader)
    try:
        out = []
        for k, m in enumerate(header.submaps):
            fields = {f: a[f"s{k}_{f}"] for f in _SUBMAP_ARRAYS}
            points = None
            if m.points:
                pts, off = a[f"s{k}_points"], a[f"s{k}_offsets"]
                points = [pts[off[i] : off[i + 1]] for i in range(len(off) - 1)]
            truth = (
                SubmapTruth(*(a[f"s{k}_truth_{f}"] for f in ("T_world_submap", "object_ids", "purity")))
                if m.truth
                else None
            )
            kf = KeyframeSet(*(a[f"s{k}_kf_{f}"] for f in KeyframeSet.FIELDS)) if m.keyframes else None
            out.append(
                Submap(
                    robot=m.robot,
                    index=m.index,
                    t=float(m.t),
                    points=points,
                    keyframes=kf,
                    truth=truth,
                    **fields,
                )
            )
        return out
    except (KeyError, IndexError, TypeError, ValueError) as err:
        raise StorageError(f"{path}: inconsistent submap file ({type(err).__name__}: {err})") from None


def save_keyframes(path: str | Path, keyframes: KeyframeSet) -> None:
    """Write one robot's keyframes (format ``roman_sim.keyframes``) atomically."""
    arrays: dict[str, Any] = {f: np.asarray(getattr(keyframes, f)) for f in KeyframeSet.FIELDS}
    write_npz(path, header=_header(KeyframesHeader("roman_sim.keyframes", FORMAT_VERSION)), **arrays)


def load_keyframes(path: str | Path) -> KeyframeSet:
    """Read a file written by ``save_keyframes``."""
    _, a = _open(path, "roman_sim.keyframes", KeyframesHeader)
    try:
        return KeyframeSet(*(a[f] for f in KeyframeSet.FIELDS))
    except KeyError as err:
        raise StorageError(f"{path}: inconsistent keyframe file (missing {err})") from None


PacketPart = Literal["segments", "keyframes", "all"]


def _compressed_size(**arrays: Any) -> int:
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return len(buf.getvalue())


def keyframe_packet_bytes(submap: Submap) -> int:
    """Bytes of the compressed keyframe packet of ``submap`` (0 without keyframes).

    Per keyframe: time, pose (float32), intrinsics, BoW vector (uint16 word ids when the
    ids fit, float32 values), ORB descriptors (32 bytes each), keypoints and their 3D
    points (float32).
    """
    kf = submap.keyframes
    if kf is None:
        return 0
    small_ids = len(kf.bow_words) == 0 or int(kf.bow_words.max()) < 2**16
    return _compressed_size(
        t=kf.t.astype(np.float64),
        T_submap_cam=kf.T_submap_cam[:, :3, :].astype(np.float32),
        intrinsics=kf.intrinsics.astype(np.float32),
        bow_offsets=kf.bow_offsets.astype(np.int32),
        bow_words=kf.bow_words.astype(np.uint16 if small_ids else np.int32),
        bow_values=kf.bow_values.astype(np.float32),
        feat_offsets=kf.feat_offsets.astype(np.int32),
        uv=kf.uv.astype(np.float32),
        descriptors=kf.descriptors,
        points=kf.points.astype(np.float32),
    )


def packet_bytes(submap: Submap, part: PacketPart = "segments") -> int:
    """Bytes of the compressed packet a robot would send for ``submap`` (public fields only).

    Args:
        submap: the submap.
        part: ``segments`` (ROMAN's packet), ``keyframes`` (the visual method's packet, see
            ``keyframe_packet_bytes``) or ``all`` (their sum).
    """
    if part not in ("segments", "keyframes", "all"):
        raise StorageError(f"packet part {part!r}: expected segments, keyframes or all")
    if part == "keyframes":
        return keyframe_packet_bytes(submap)
    seg = _compressed_size(**packet_arrays(submap))
    return seg + (keyframe_packet_bytes(submap) if part == "all" else 0)


def packet_arrays(submap: Submap) -> dict[str, np.ndarray]:
    """The arrays of ``submap``'s segment packet, in the dtypes a robot sends (public fields only).

    Pose and time float64, index and segment ids int32, centres, volumes, shape and extents
    float32, descriptors float16; ``packet_bytes`` is the size of their compressed archive.
    """
    s = submap.public()
    return {
        "T_odom_submap": np.asarray(s.T_odom_submap, dtype=np.float64),
        "t": np.asarray(s.t, dtype=np.float64),
        "index": np.asarray(s.index, dtype=np.int32),
        "segment_ids": s.segment_ids.astype(np.int32),
        "centers": s.centers.astype(np.float32),
        "volumes": s.volumes.astype(np.float32),
        "shape": s.shape.astype(np.float32),
        "extents": s.extents.astype(np.float32),
        "descriptors": np.asarray(s.descriptors).astype(np.float16),
    }


def mb_per_km(total_bytes: int | float, length_m: float) -> float:
    """Megabytes (1e6 bytes) per kilometre of trajectory; NaN for a zero-length trajectory."""
    return float(total_bytes) / 1e6 / (length_m / 1000.0) if length_m > 0 else float("nan")


def submaps_mb_per_km(submaps: list[Submap], length_m: float, part: PacketPart = "segments") -> float:
    """Packet megabytes per kilometre for a robot's submaps over ``length_m`` of trajectory."""
    return mb_per_km(sum(packet_bytes(s, part) for s in submaps), length_m)
