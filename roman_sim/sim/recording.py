"""Recordings: a robot run stored compactly so mapping can be re-run without rendering.

Layout of a recording folder::

    meta.json         format version, robot, intrinsics, T_body_cam, frame count, chunks
    traj_true.tum     true body trajectory (TUM, evo-readable)
    traj_odom.tum     drifted odometry trajectory (TUM)
    chunk_00000.npz   up to ``chunk_size`` frames: t, index, T_world_body, T_odom_body,
                      depth_mm (uint16 millimetres, 0 invalid), object_ids (int16 or int32),
                      rgb (uint8, when rendered)

The folder is written under a temporary name next to ``out_dir`` and renamed at the end,
so an interrupted run never leaves a half-written recording. Depth is stored at 1 mm
resolution (readings above 65.535 m are stored as invalid). Chunks are zip files with
fixed timestamps, so the same frames give the same bytes.
"""

from __future__ import annotations

import io
import logging
import os
import shutil
import tempfile
import zipfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.atomic import make_public_dir, output_folder
from roman_sim.core.errors import ConfigError, RecordingError
from roman_sim.core.records import NONE_AS_EMPTY, OMIT_NONE, RecordError, from_json, read_json, write_record
from roman_sim.core.sensors import Frame, FrameTruth, Intrinsics
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import write_tum

log = logging.getLogger(__name__)

FORMAT = "roman_sim.recording"
FORMAT_VERSION = 1
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def _write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Compressed npz with fixed member timestamps (deterministic bytes)."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, arr in arrays.items():
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.ascontiguousarray(arr), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            zf.writestr(info, buf.getvalue())


def _truth(f: Frame) -> FrameTruth:
    if f.truth is None or f.truth.object_ids is None:
        raise RecordingError(
            f"frame {f.index} of robot {f.robot}: a recording stores ground truth "
            "(poses and instance ids), this frame has none"
        )
    return f.truth


def _object_ids(f: Frame) -> NDArray[np.int32]:
    ids = _truth(f).object_ids
    assert ids is not None  # _truth rejects frames without instance ids
    return ids


def _pack(frames: list[Frame]) -> dict[str, np.ndarray]:
    depth = np.stack([f.depth for f in frames]).astype(np.float64)
    depth_mm = np.where((depth > 0) & (depth <= 65.535), np.rint(depth * 1000.0), 0).astype(np.uint16)
    ids = np.stack([_object_ids(f) for f in frames])
    id_type = np.int16 if ids.size == 0 or (ids.max() < 32767 and ids.min() >= -1) else np.int32
    out: dict[str, np.ndarray] = {
        "t": np.array([f.t for f in frames], dtype=np.float64),
        "index": np.array([f.index for f in frames], dtype=np.int64),
        "T_world_body": np.stack([_truth(f).T_world_body for f in frames]).astype(np.float64),
        "T_odom_body": np.stack([f.T_odom_body for f in frames]).astype(np.float64),
        "depth_mm": depth_mm,
        "object_ids": ids.astype(id_type),
    }
    rgb = [f.rgb for f in frames if f.rgb is not None]  # all frames or none (_check_consistent)
    if rgb:
        out["rgb"] = np.stack(rgb).astype(np.uint8)
    return out


def _check_consistent(first: Frame, f: Frame) -> None:
    if f.robot != first.robot or f.intrinsics != first.intrinsics or (f.rgb is None) != (first.rgb is None):
        raise RecordingError(f"frame {f.index}: robot, intrinsics or rgb presence differ from the first frame")
    if not np.allclose(f.T_body_cam, first.T_body_cam):
        raise RecordingError(f"frame {f.index}: T_body_cam differs from the first frame")


@dataclass(frozen=True)
class RecordingOrigin:
    """Where a recording came from: its scenario and seed, and the key of the run that made it."""

    scenario: str
    seed: int
    key: str | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class RecordingMeta:
    """What a recording's ``meta.json`` holds: its format, robot, frame count, chunk files, whether
    frames carry RGB, the camera, and where it came from (None: not said; written as ``{}``)."""

    format: str
    format_version: int
    robot: str
    frame_count: int
    chunks: list[str]
    has_rgb: bool
    intrinsics: Intrinsics
    T_body_cam: list[list[float]]
    extra: RecordingOrigin | None = field(default=None, metadata=NONE_AS_EMPTY)


def _meta(first: Frame, n: int, chunks: list[str], origin: RecordingOrigin | None) -> RecordingMeta:
    k = first.intrinsics
    intr = Intrinsics(k.width, k.height, float(k.fx), float(k.fy), float(k.cx), float(k.cy))
    T_bc: list[list[float]] = np.asarray(first.T_body_cam, dtype=np.float64).tolist()
    return RecordingMeta(FORMAT, FORMAT_VERSION, first.robot, n, chunks, first.rgb is not None, intr, T_bc, origin)


def write_recording(
    frames: Iterable[Frame],
    out_dir: str | Path,
    chunk_size: int = 50,
    overwrite: bool = False,
    origin: RecordingOrigin | None = None,
) -> Path:
    """Store ``frames`` (one robot) in ``out_dir``; returns the folder path.

    Args:
        frames: the frames, in order (e.g. a frame source's ``frames()``; consumed lazily).
        out_dir: destination folder; must not exist unless ``overwrite``.
        chunk_size: frames per npz chunk.
        overwrite: replace an existing recording.
        origin: the scenario, seed and run key it came from (``meta.json``'s ``extra``).

    Raises: RecordingError for an existing destination, no frames or inconsistent frames.
    """
    out = Path(out_dir)
    if chunk_size < 1:
        raise RecordingError(f"chunk_size must be >= 1, got {chunk_size}")
    if out.exists() and not overwrite:
        raise RecordingError(f"{out}: already exists (pass overwrite=True to replace it)")
    if out.exists() and not out.is_dir():
        raise RecordingError(f"{out}: is an existing file, not a recording folder")
    try:
        output_folder(out.parent, "recording folder")
    except ConfigError as err:
        raise RecordingError(str(err)) from None
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    make_public_dir(tmp)
    try:
        _write_into(frames, tmp, chunk_size, origin)
        if out.exists():
            shutil.rmtree(out)
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    log.info("recording written to %s", out)
    return out


def _write_into(frames: Iterable[Frame], tmp: Path, chunk_size: int, origin: RecordingOrigin | None) -> None:
    first: Frame | None = None
    buf: list[Frame] = []
    chunks: list[str] = []
    t, T_true, T_odom = [], [], []

    def flush() -> None:
        name = f"chunk_{len(chunks):05d}.npz"
        _write_npz(tmp / name, _pack(buf))
        chunks.append(name)
        buf.clear()

    for f in frames:
        first = first or f
        _check_consistent(first, f)
        buf.append(f)
        t.append(f.t)
        T_true.append(_truth(f).T_world_body)
        T_odom.append(f.T_odom_body)
        if len(buf) == chunk_size:
            flush()
    if first is None:
        raise RecordingError("recording: no frames to write")
    if buf:
        flush()
    times = np.asarray(t, dtype=np.float64)
    write_tum(tmp / "traj_true.tum", Trajectory(times, np.asarray(T_true).reshape(-1, 4, 4)))
    write_tum(tmp / "traj_odom.tum", Trajectory(times, np.asarray(T_odom).reshape(-1, 4, 4)))
    write_record(tmp / "meta.json", _meta(first, len(t), chunks, origin))


def recording_info(rec_dir: str | Path) -> RecordingMeta:
    """The recording's ``meta.json``, checked (format, version, every field, chunk files present)."""
    d = Path(rec_dir)
    meta_path = d / "meta.json"
    if not meta_path.is_file():
        raise RecordingError(f"{d}: not a recording (meta.json missing)")
    try:
        data = read_json(meta_path)
    except RecordError as err:
        raise RecordingError(f"{err} (corrupt meta.json)") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise RecordingError(f"{meta_path}: not a roman_sim recording")
    if data.get("format_version") != FORMAT_VERSION:
        raise RecordingError(
            f"{meta_path}: format version {data.get('format_version')!r} is not supported (expected {FORMAT_VERSION})"
        )
    try:
        meta = from_json(RecordingMeta, data, str(meta_path))
    except RecordError as err:
        raise RecordingError(f"{err} (incomplete metadata)") from None
    missing = [c for c in meta.chunks if not (d / c).is_file()]
    if missing:
        raise RecordingError(f"{d}: missing chunk file(s): {', '.join(missing)}")
    return meta


def _load_chunk(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
        raise RecordingError(f"{path}: corrupt chunk ({type(err).__name__}: {err})") from None


def read_recording(rec_dir: str | Path) -> Iterator[Frame]:
    """Frames of a recording, in order (depth back in metres as float32, ids as int32)."""
    d = Path(rec_dir)
    meta = recording_info(d)
    intr, robot = meta.intrinsics, meta.robot
    try:
        T_bc = np.asarray(meta.T_body_cam, dtype=np.float64).reshape(4, 4)
    except ValueError as err:
        raise RecordingError(f"{d / 'meta.json'}: incomplete metadata ({err})") from None
    for name in meta.chunks:
        c = _load_chunk(d / name)
        try:
            for i in range(len(c["t"])):
                yield Frame(
                    robot,
                    int(c["index"][i]),
                    float(c["t"][i]),
                    c["rgb"][i] if "rgb" in c else None,
                    (c["depth_mm"][i].astype(np.float32) / np.float32(1000.0)),
                    c["T_odom_body"][i],
                    T_bc.copy(),
                    intr,
                    truth=FrameTruth(c["object_ids"][i].astype(np.int32), c["T_world_body"][i]),
                )
        except (KeyError, IndexError) as err:
            raise RecordingError(f"{d / name}: corrupt chunk (missing or short array: {err})") from None


class Recording:
    """A recording folder as a ``FrameSource`` (its ``meta.json`` read and checked up front).

    Raises: RecordingError when the folder is not a readable recording.
    """

    def __init__(self, rec_dir: str | Path) -> None:
        self.dir = Path(rec_dir)
        self.meta = recording_info(self.dir)
        self._intrinsics, self._name, self._n = self.meta.intrinsics, self.meta.robot, self.meta.frame_count
        try:
            self._T_body_cam = np.asarray(self.meta.T_body_cam, dtype=np.float64).reshape(4, 4)
        except ValueError as err:
            raise RecordingError(f"{self.dir / 'meta.json'}: incomplete metadata ({err})") from None

    @property
    def name(self) -> str:
        """The recorded robot's name."""
        return self._name

    @property
    def intrinsics(self) -> Intrinsics:
        """The camera intrinsics."""
        return self._intrinsics

    @property
    def T_body_cam(self) -> NDArray[np.float64]:
        """The camera (RDF optical) pose in the body (FLU) frame."""
        return self._T_body_cam.copy()

    def __len__(self) -> int:
        return self._n

    def frames(self, indices: Iterable[int] | None = None) -> Iterator[Frame]:
        """The recorded frames in order (``read_recording``); only the ``indices``-th ones if given."""
        if indices is None:
            yield from read_recording(self.dir)
            return
        keep = {int(i) for i in indices}
        for k, frame in enumerate(read_recording(self.dir)):
            if k in keep:
                yield frame
