"""Segment masks drawn over a camera image: what the front end hands to the mapper.

Each mask is filled with its own colour (half transparent) and outlined, so split and
merged objects and missed ones can be seen at a glance. Masks whose majority true object is
known are numbered with it.
"""

from __future__ import annotations

import logging
import zlib
from collections.abc import Sequence
from colorsys import hsv_to_rgb
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from roman_sim.core.errors import EvaluationError
from roman_sim.core.figures import save_figure
from roman_sim.report.plots import figure

log = logging.getLogger(__name__)


def _colour(i: int) -> NDArray[np.float64]:
    h = zlib.crc32(str(i).encode()) / 2**32
    return np.array(hsv_to_rgb(h, 0.8, 1.0))


def overlay(rgb: NDArray[np.uint8], masks: Sequence[NDArray[np.bool_]], alpha: float = 0.5) -> NDArray[np.float64]:
    """(H, W, 3) float image: ``rgb`` with each mask blended in its colour and outlined in white.

    Raises:
        EvaluationError: a mask whose shape differs from the image's.
    """
    img = np.asarray(rgb, dtype=np.float64)[..., :3] / 255.0
    out = img.copy()
    for i, m in enumerate(masks):
        m = np.asarray(m, dtype=bool)
        if m.shape != img.shape[:2]:
            raise EvaluationError(f"mask {i} has shape {m.shape}, the image {img.shape[:2]}")
        out[m] = (1 - alpha) * out[m] + alpha * _colour(i)
        edge = m & ~ndimage.binary_erosion(m)
        out[edge] = 1.0
    return out


def plot_masks(
    rgb: NDArray[np.uint8],
    masks: Sequence[NDArray[np.bool_]],
    path: str | Path,
    title: str,
    labels: Sequence[str | None] | None = None,
) -> Path:
    """Write the image with the masks over it (labels at each mask's centroid when given)."""
    img = overlay(rgb, masks)
    h, w = img.shape[:2]
    fig = figure(6.0, 6.0 * h / w + 0.6)
    ax = fig.axes[0]
    ax.imshow(img, interpolation="nearest")
    for m, lab in zip(masks, labels or []):
        if lab:
            r, c = np.argwhere(m).mean(axis=0)
            ax.text(
                c,
                r,
                lab,
                color="black",
                fontsize=6,
                ha="center",
                va="center",
                bbox={"boxstyle": "round,pad=0.1", "fc": "white", "alpha": 0.7, "lw": 0},
            )
    ax.set_axis_off()
    ax.set_title(title, fontsize=8)
    return save_figure(fig, path)
