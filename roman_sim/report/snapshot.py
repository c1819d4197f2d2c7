"""The front-end snapshot: one camera image of a robot with its segmenter's masks, kept and drawn.

The maps stage keeps it (``FrameSnapshot.of`` a frame and its masks; saved with
``save_snapshot`` as ``maps/snapshot.npz``), so the report draws it from saved data
(``snapshot_files``) without rendering or segmenting anything. The numbers drawn on the masks
are each mask's majority true object (from the frame's instance truth, when it has one).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.atomic import write_arrays
from roman_sim.core.errors import StorageError
from roman_sim.core.figures import FigureFiles
from roman_sim.core.records import dumps_record, loads_record
from roman_sim.core.sensors import Frame

FORMAT = "roman_sim.frame_snapshot"


def majority_label(object_ids: NDArray[np.signedinteger], pixels: NDArray[np.bool_]) -> str | None:
    """The most frequent true object id under a mask (None when it covers only terrain/sky)."""
    ids = object_ids[pixels]
    ids = ids[ids >= 0]
    return None if not len(ids) else str(int(np.bincount(ids).argmax()))


@dataclass
class FrameSnapshot:
    """A camera image and the masks a segmenter cut from it.

    Attributes:
        robot: the robot's name.
        t: the frame's time (s).
        rgb: (H, W, 3) the colour image.
        masks: (K, H, W) the masks.
        labels: each mask's majority true object id (None: terrain/sky, or no instance truth).
        segmenter: what the title calls the segmenter.
    """

    robot: str
    t: float
    rgb: NDArray[np.uint8]
    masks: NDArray[np.bool_]
    labels: list[str | None]
    segmenter: str

    @classmethod
    def of(cls, frame: Frame, masks: Sequence[NDArray[np.bool_]], segmenter: str) -> FrameSnapshot:
        """The snapshot of ``frame`` (it must have RGB) and its ``masks``' pixels.

        Raises: StorageError when the frame has no colour image.
        """
        if frame.rgb is None:
            raise StorageError(f"robot {frame.robot}: frame {frame.index} has no colour image")
        ids = frame.truth.object_ids if frame.truth is not None else None
        shape = (frame.intrinsics.height, frame.intrinsics.width)
        stack = np.array(masks, dtype=bool).reshape(len(masks), *shape)
        labels = [None if ids is None else majority_label(ids, m) for m in stack]
        return cls(frame.robot, float(frame.t), np.asarray(frame.rgb, dtype=np.uint8), stack, labels, segmenter)

    @property
    def title(self) -> str:
        """The figure's title."""
        return (
            f"robot {self.robot} at t = {self.t:.1f} s: {len(self.masks)} masks of the "
            f"{self.segmenter} segmenter (numbers: majority true object)"
        )


@dataclass(frozen=True)
class SnapshotHeader:
    """The header of a snapshot file: robot, time, each mask's label and the segmenter."""

    format: str
    robot: str
    t: float
    labels: list[str | None]
    segmenter: str


def save_snapshot(path: str | Path, snap: FrameSnapshot) -> None:
    """Write ``snap`` atomically (masks bit-packed)."""
    header = SnapshotHeader(FORMAT, snap.robot, snap.t, snap.labels, snap.segmenter)
    write_arrays(
        path,
        {
            "header": np.frombuffer(dumps_record(header).encode("utf-8"), dtype=np.uint8),
            "rgb": snap.rgb,
            "masks": np.packbits(snap.masks, axis=-1),
            "shape": np.array(snap.masks.shape, dtype=np.int64),
        },
    )


def load_snapshot(path: str | Path) -> FrameSnapshot:
    """The snapshot ``save_snapshot`` wrote (StorageError when unreadable)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            header = loads_record(z["header"].tobytes(), SnapshotHeader, f"{path}: header")
            shape = tuple(int(v) for v in z["shape"])
            masks = np.unpackbits(z["masks"], axis=-1, count=shape[-1]).astype(bool).reshape(shape)
            rgb = z["rgb"]
        if header.format != FORMAT:
            raise ValueError("not a frame snapshot")
        return FrameSnapshot(header.robot, float(header.t), rgb, masks, list(header.labels), header.segmenter)
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise StorageError(f"{path}: unreadable front-end snapshot ({type(err).__name__}: {err})") from None


def snapshot_files(snap: FrameSnapshot) -> FigureFiles:
    """The image with the masks over it, as PNG and PDF bytes."""
    from roman_sim.report.render import masks_files

    return masks_files(snap.rgb, list(snap.masks), snap.title, snap.labels)


def snapshot_job(snap: FrameSnapshot) -> tuple[FigureFiles | None, list[str]]:
    """The snapshot as a report figure job (``render.Drawn``: its files and no notes)."""
    return snapshot_files(snap), []
