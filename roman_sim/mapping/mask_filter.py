"""ROMAN's own mask filters, shared by every image segmenter.

A mask is kept when its area lies within [A / min_area_div^2, A / max_area_div^2]
(A = image width x height; 30 and 3 in the reference), then eroded with an elliptical
kernel of radius ``erosion_px`` (3 in the reference, sized for 640 x 480) scaled to the
image width as ``scaled_px`` does (``roman_sim.mapping.mask``): 2 px at 320 x 240, 1 px at
160 x 120, so the filters keep the same share of every object at any resolution.

A label image is eroded in one pass (``eroded_labels``: a pixel keeps its label where the
kernel around it holds that label only), which is every label's own binary erosion at once;
``masks_from_labels_reference`` erodes label by label in bounding-box windows.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator
from scipy import ndimage

from roman_sim.core.config import StrictModel
from roman_sim.mapping.mask import Mask, ellipse_kernel, scaled_px


class MaskFilterConfig(StrictModel):
    """Area window and erosion of ROMAN's mask filter (``erosion_px`` at 640 px width, scaled to the image)."""

    min_area_div: float = Field(30.0, gt=1)
    max_area_div: float = Field(3.0, gt=0)
    erosion_px: int = Field(3, ge=0, le=20, description="erosion radius at 640 px width (scaled to the image)")

    @model_validator(mode="after")
    def _window(self) -> MaskFilterConfig:
        if self.max_area_div >= self.min_area_div:
            raise ValueError("max_area_div must be smaller than min_area_div")
        return self

    def area_range(self, shape: tuple[int, int]) -> tuple[float, float]:
        """(smallest, largest) kept area in pixels for an image of ``shape``."""
        A = float(shape[0] * shape[1])
        return A / self.min_area_div**2, A / self.max_area_div**2

    def erosion_radius(self, width: int) -> int:
        """Erosion radius (pixels) for an image ``width`` pixels wide."""
        return scaled_px(self.erosion_px, width)


@functools.lru_cache(maxsize=16)
def _kernel(radius: int) -> NDArray[np.uint8]:
    """The simulated segmenter's elliptical kernel, as OpenCV wants it (built once per radius; read-only)."""
    k = ellipse_kernel(radius).astype(np.uint8)
    k.flags.writeable = False
    return k


def eroded_labels(labels: NDArray[np.integer], radius: int) -> NDArray[np.integer]:
    """Every label's binary erosion (elliptical kernel of ``radius``) in one label image.

    A pixel keeps its label where every pixel of the kernel around it has that label, and
    pixels outside the image count as background (label 0): the union of
    ``binary_erosion(labels == k, kernel, border_value=0) * k`` over every label k >= 1.
    Computed as OpenCV's erosion and dilation of the labels (the neighbourhood's minimum
    equals its maximum only where it holds a single label); labels beyond 16 bits or below 0
    are compared one kernel offset at a time.
    """
    lab = np.asarray(labels)
    if radius <= 0 or lab.size == 0:
        return np.where(lab > 0, lab, 0).astype(lab.dtype, copy=False)
    kernel = _kernel(radius)
    lo_val, hi_val = int(lab.min()), int(lab.max())
    if lab.ndim == 2 and lo_val >= 0 and hi_val <= np.iinfo(np.uint16).max:
        import cv2  # imported on use: loading a configuration should not import OpenCV

        u = lab.astype(np.uint16)
        lo = cv2.erode(u, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0)
        hi = cv2.dilate(u, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0)
        return np.where((lo == hi) & (lab > 0), lab, 0).astype(lab.dtype, copy=False)
    h, w = lab.shape
    pad = np.zeros((h + 2 * radius, w + 2 * radius), dtype=lab.dtype)
    pad[radius : radius + h, radius : radius + w] = lab
    same = lab > 0
    for dy, dx in zip(*np.nonzero(kernel)):
        same &= pad[dy : dy + h, dx : dx + w] == lab
    return np.where(same, lab, 0).astype(lab.dtype, copy=False)


def masks_from_labels(labels: NDArray[np.int32], cfg: MaskFilterConfig) -> list[Mask]:
    """Filtered, eroded masks of every label >= 1 of a label image (0 = no mask), in label order."""
    lo, hi = cfg.area_range(labels.shape)
    n = int(labels.max()) if labels.size else 0
    if n < 1:
        return []
    areas = np.bincount(labels.ravel(), minlength=n + 1)
    eroded = eroded_labels(labels, cfg.erosion_radius(labels.shape[1]))
    slices = ndimage.find_objects(eroded, max_label=n)  # the eroded masks' bounding boxes
    out = []
    for k in np.flatnonzero((areas >= lo) & (areas <= hi)).tolist():
        sl = slices[k - 1] if k > 0 else None
        if sl is None:
            continue  # nothing left after erosion
        full = np.zeros(labels.shape, dtype=bool)
        np.equal(eroded[sl], k, out=full[sl])
        out.append(Mask(full, (), (sl[0].start, sl[0].stop, sl[1].start, sl[1].stop)))
    return out


def masks_from_labels_reference(labels: NDArray[np.int32], cfg: MaskFilterConfig) -> list[Mask]:
    """``masks_from_labels`` eroding one label at a time in its bounding-box window."""
    lo, hi = cfg.area_range(labels.shape)
    n = int(labels.max()) if labels.size else 0
    if n < 1:
        return []
    areas = np.bincount(labels.ravel(), minlength=n + 1)
    slices = ndimage.find_objects(labels)
    out = []
    for k in np.flatnonzero((areas >= lo) & (areas <= hi)):
        if k == 0 or slices[k - 1] is None:
            continue
        sl = slices[k - 1]
        m = _eroded(labels, sl, int(k), cfg.erosion_radius(labels.shape[1]))
        if m is not None:
            out.append(m)
    return out


def filter_masks(masks: list[NDArray[np.bool_]], cfg: MaskFilterConfig) -> list[Mask]:
    """Filtered, eroded ``Mask`` objects from full-image boolean masks (order kept)."""
    out = []
    for pix in masks:
        pix = np.asarray(pix, dtype=bool)
        lo, hi = cfg.area_range(pix.shape)
        area = int(pix.sum())
        if not lo <= area <= hi:
            continue
        sl = ndimage.find_objects(pix.astype(np.int32))[0]
        m = _eroded(pix.astype(np.int32), sl, 1, cfg.erosion_radius(pix.shape[1]))
        if m is not None:
            out.append(m)
    return out


def _eroded(labels: NDArray[np.int32], sl: tuple[slice, slice], k: int, radius: int) -> Mask | None:
    """Mask of label ``k`` inside the window ``sl``, eroded; None when nothing survives."""
    h, w = labels.shape
    p = radius + 1
    r0, r1 = max(sl[0].start - p, 0), min(sl[0].stop + p, h)
    c0, c1 = max(sl[1].start - p, 0), min(sl[1].stop + p, w)
    win = (labels[r0:r1, c0:c1] == k).astype(np.uint8)
    if radius:
        import cv2  # imported on use: loading a configuration should not import OpenCV

        # Pixels outside the image count as background, as in binary erosion with border 0.
        win = cv2.erode(win, _kernel(radius), borderType=cv2.BORDER_CONSTANT, borderValue=0)
    rows, cols = np.nonzero(win)
    if len(rows) == 0:
        return None
    full = np.zeros((h, w), dtype=bool)
    full[r0:r1, c0:c1] = win.astype(bool)
    bbox = (r0 + int(rows.min()), r0 + int(rows.max()) + 1, c0 + int(cols.min()), c0 + int(cols.max()) + 1)
    return Mask(full, (), bbox)
