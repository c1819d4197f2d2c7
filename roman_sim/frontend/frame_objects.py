"""The objects of one frame's instance image: pixel counts, bounding boxes, median depths, neighbours.

The simulated segmenter and the front-end grader both read a frame's true instance image and
need the same facts about it. ``frame_objects(ids, depth)`` computes them once per frame: the
result of the last few frames is kept and handed out again for the very same arrays (the
frame's own ``object_ids`` and ``depth``, which nothing changes in place). Median depths and
neighbour pairs are computed on demand and kept.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from roman_sim.frontend.mask_noise import neighbour_pairs

#: How many frames' tables are kept (the segmenter's and the grader's frame are the same one).
_KEPT = 2
_recent: deque[FrameObjects] = deque(maxlen=_KEPT)
_lock = threading.Lock()


@dataclass
class FrameObjects:
    """The objects of an instance image ``ids`` (-1 background) with its ``depth`` (0 invalid).

    Attributes:
        ids: (H, W) object ids, as given.
        depth: (H, W) depth, as given.
        labels: (H, W) int32 ``ids + 1`` (0 background).
        counts: pixels per label (index id + 1).
        boxes: bounding box per label from ``scipy.ndimage.find_objects`` (index id; None: absent).
        present: ids with at least one pixel, ascending.
    """

    ids: NDArray[np.int32]
    depth: NDArray[np.float32]
    labels: NDArray[np.int32]
    counts: NDArray[np.int64]
    boxes: list[tuple[slice, slice] | None]
    present: list[int]
    _depths: dict[int, float] = field(default_factory=dict)
    _pairs: dict[int, dict[tuple[int, int], int]] = field(default_factory=dict)

    @classmethod
    def of(cls, ids: NDArray[np.int32], depth: NDArray[np.float32]) -> FrameObjects:
        """The objects of the instance image ``ids`` (ids below -1 are an error, as in ``np.bincount``)."""
        labels = (np.asarray(ids) + 1).astype(np.int32, copy=False)
        counts = np.bincount(labels.ravel())
        boxes = ndimage.find_objects(labels, max_label=len(counts) - 1)
        present = (np.flatnonzero(counts[1:])).tolist()
        return cls(ids, depth, labels, counts, boxes, present)

    def box(self, o: int) -> tuple[slice, slice]:
        """Bounding box of object ``o`` (present)."""
        sl = self.boxes[o]
        assert sl is not None, f"object {o} is not in the image"
        return sl

    def depth_of(self, o: int) -> float:
        """Median valid depth of object ``o`` (inf without valid depth; computed once, on demand)."""
        if o not in self._depths:
            sl = self.box(o)
            self._depths[o] = median_depth(self.depth[sl], self.ids[sl] == o)
        return self._depths[o]

    def neighbour_pairs(self, max_gap_px: int) -> dict[tuple[int, int], int]:
        """``mask_noise.neighbour_pairs(ids, max_gap_px)`` (from a wider search when one was made)."""
        if max_gap_px not in self._pairs:
            wider = [g for g in self._pairs if g > max_gap_px]
            if wider:
                found = self._pairs[min(wider)]
                self._pairs[max_gap_px] = {k: g for k, g in found.items() if g <= max_gap_px}
            else:
                self._pairs[max_gap_px] = neighbour_pairs(self.ids, max_gap_px)
        return self._pairs[max_gap_px]


def frame_objects(ids: NDArray[np.int32], depth: NDArray[np.float32]) -> FrameObjects:
    """``FrameObjects.of(ids, depth)``, shared by every caller that passes these very arrays."""
    with _lock:
        for f in _recent:
            if f.ids is ids and f.depth is depth:
                return f
    f = FrameObjects.of(ids, depth)
    with _lock:
        _recent.append(f)
    return f


def median_depth(depth: NDArray[np.float32], pix: NDArray[np.bool_]) -> float:
    """Median valid depth under ``pix`` (inf without valid depth)."""
    d = depth[pix]
    d = d[d > 0]
    return float(np.median(d)) if len(d) else math.inf
