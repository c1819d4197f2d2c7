"""PNG images of standard sequences: RGB, 16-bit depth and 16-bit instance masks.

Conventions (those of the TUM RGB-D benchmark):

- depth: 16-bit grey PNG, ``value = round(depth_m * scale)`` (``scale`` 5000 per metre by
  default, i.e. 0.2 mm steps), 0 = no reading. A reading that does not fit in 16 bits
  (deeper than ``65535 / scale`` m, 13.107 m at 5000) is stored as 0 (invalid) rather
  than clipped, so no wrong depth is ever written. Reading back gives ``value / scale``:
  the round trip is exact to half a unit (``0.5 / scale`` m) plus float32 rounding.
- instance masks: 16-bit grey PNG of ``object_id + 1``; 0 is background (terrain, sky),
  so object ``k`` of the object table has mask value ``k + 1``.

PNGs are written by Pillow with a fixed zlib level and no metadata chunks, so the same
array gives the same bytes. Level 1 is the default: on 640 x 480 frames of the demo world it
encodes RGB + depth + mask in about 85 ms against 230 ms at level 6, for files 13 % larger.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from PIL import Image, UnidentifiedImageError

from roman_sim.core.errors import StorageError

#: Depth units per metre of the TUM RGB-D benchmark.
TUM_DEPTH_SCALE = 5000.0
#: Largest object id a 16-bit mask can hold (value 65535 = id 65534).
MAX_MASK_ID = 65534
DEFAULT_COMPRESS_LEVEL = 1


def encode_png(image: NDArray[np.uint8] | NDArray[np.uint16], compress_level: int = DEFAULT_COMPRESS_LEVEL) -> bytes:
    """PNG bytes of an (H, W, 3) uint8 RGB image or an (H, W) uint16 / uint8 grey image (zlib level 0-9)."""
    a = np.ascontiguousarray(image)
    grey16 = a.dtype == np.uint16 and a.ndim == 2
    if grey16 or a.dtype == np.uint8 and (a.ndim == 2 or a.ndim == 3 and a.shape[2] == 3):
        img = Image.fromarray(a)
    else:
        raise StorageError(f"PNG: unsupported image of shape {a.shape} and dtype {a.dtype}")
    buf = io.BytesIO()
    if not 0 <= compress_level <= 9:
        raise StorageError(f"PNG compress_level must be 0..9, got {compress_level}")
    img.save(buf, format="PNG", compress_level=compress_level)
    return buf.getvalue()


def read_png(path: str | Path) -> NDArray[np.uint8] | NDArray[np.uint16]:
    """A PNG as an array: (H, W, 3) uint8 for colour, (H, W) uint16 for 16-bit grey."""
    p = Path(path)
    try:
        with Image.open(p) as img:
            mode = img.mode
            if mode in ("I;16", "I;16B", "I"):
                return np.asarray(img).astype(np.uint16)
            if mode == "L":
                return np.asarray(img).copy()
            return np.asarray(img.convert("RGB")).copy()
    except FileNotFoundError:
        raise StorageError(f"{p}: image file not found") from None
    except (OSError, UnidentifiedImageError, ValueError) as err:
        raise StorageError(f"{p}: not a readable PNG ({err})") from None


def depth_to_units(depth_m: NDArray[np.floating], scale: float = TUM_DEPTH_SCALE) -> tuple[NDArray[np.uint16], int]:
    """16-bit depth units of a metric depth image, and the number of valid readings dropped.

    Invalid readings (0, negative, NaN, inf) and readings deeper than ``65535 / scale`` m
    become 0; the count returned is that of the too-deep ones.
    """
    d = np.asarray(depth_m, dtype=np.float64)
    units = np.rint(d * scale)
    valid = np.isfinite(d) & (d > 0)
    fits = valid & (units <= 65535) & (units >= 1)
    too_deep = int(np.count_nonzero(valid & (units > 65535)))
    return np.where(fits, units, 0).astype(np.uint16), too_deep


def units_to_depth(units: NDArray[np.integer], scale: float = TUM_DEPTH_SCALE) -> NDArray[np.float32]:
    """Metric float32 depth of 16-bit depth units (0 stays 0 = invalid)."""
    if scale <= 0 or not np.isfinite(scale):
        raise StorageError(f"depth_scale must be a finite positive number of units per metre, got {scale}")
    return (np.asarray(units, dtype=np.float64) / scale).astype(np.float32)


def ids_to_mask(object_ids: NDArray[np.integer]) -> NDArray[np.uint16]:
    """16-bit mask values (``id + 1``, 0 background) of an instance-id image (-1 background)."""
    ids = np.asarray(object_ids)
    if ids.size and (int(ids.max()) > MAX_MASK_ID or int(ids.min()) < -1):
        raise StorageError(f"instance mask: ids must lie in [-1, {MAX_MASK_ID}], got [{ids.min()}, {ids.max()}]")
    return (ids.astype(np.int64) + 1).astype(np.uint16)


def mask_to_ids(mask: NDArray[np.integer]) -> NDArray[np.int32]:
    """Instance-id image (-1 background) of 16-bit mask values."""
    return np.asarray(mask, dtype=np.int32) - 1
