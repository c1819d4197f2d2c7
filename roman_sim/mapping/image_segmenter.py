"""A segmenter that sees only pixels: colour regions cut and joined by depth, then ROMAN's filters.

Steps, at a working resolution (``work_width`` columns; the paper ran FastSAM at 256 x 256):

1. Felzenszwalb's graph-based segmentation of the colour image (scikit-image).
2. Depth is averaged over valid pixels (0 < depth <= ``max_depth_m``) and its surface
   normals are compared with gravity (from the odometry pose: VIO observes roll and pitch);
   pixels whose normal is within ``ground_normal_deg`` of up are ground.
3. Two neighbouring pixels stay in one region when they share a colour region, both have
   valid depth, agree on ground / not ground and their depths differ by at most
   ``max(depth_jump_m, depth_jump_rel * depth)`` (connected components, scipy).
4. Non-ground regions whose shared border is mostly depth-continuous are merged (one
   object split by colour: trunk and crown); ground regions are dropped.
5. Labels go back to full resolution (invalid depth pixels excluded) and pass ROMAN's mask
   filters (area window, elliptical erosion).

It reads ``rgb``, ``depth``, ``T_odom_body``, ``T_body_cam`` and the intrinsics, never
``frame.truth``; the result is a deterministic function of those pixels.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import Field
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from roman_sim.core.errors import MappingError
from roman_sim.mapping.mask_filter import MaskFilterConfig, masks_from_labels
from roman_sim.mapping.segmenter import Mask
from roman_sim.sensors import Frame


class ImageSegmenterConfig(MaskFilterConfig):
    """Parameters of the image segmenter (ROMAN's mask filter fields included)."""

    work_width: int = Field(160, ge=16, le=4096, description="columns of the working resolution")
    scale: float = Field(80.0, gt=0, description="Felzenszwalb scale (larger: larger regions)")
    sigma: float = Field(0.5, ge=0, le=5)
    min_size_px: int = Field(12, ge=1, description="smallest colour region at the working resolution")
    max_depth_m: float = Field(7.5, gt=0, le=100)
    depth_jump_m: float = Field(0.25, gt=0, le=10)
    depth_jump_rel: float = Field(0.06, ge=0, le=1)
    smooth_px: int = Field(2, ge=0, le=10, description="radius of the valid-depth box filter")
    ground_normal_deg: float = Field(30.0, ge=0, le=90, description="normals this close to up are ground")
    merge_min_continuous: float = Field(0.6, ge=0, le=1.01, description="share of a border that must be "
                                        "depth-continuous to merge two regions (> 1: never merge)")


class ImageSegmenter:
    """Truth-free masks from RGB and depth (see the module docstring)."""

    needs_rgb = True
    reads_truth = False

    def __init__(self, cfg: ImageSegmenterConfig | None = None) -> None:
        self.cfg = cfg or ImageSegmenterConfig()

    def segment(self, frame: Frame) -> list[Mask]:
        """Masks of one frame (``frame.rgb`` required)."""
        if frame.rgb is None:
            raise MappingError(f"image segmenter: frame {frame.index} of robot {frame.robot} has no RGB "
                               "(set render_rgb: true for this robot)")
        labels = self.labels(frame)
        return masks_from_labels(labels, self.cfg)

    def labels(self, frame: Frame) -> NDArray[np.int32]:
        """(H, W) int32 region labels at full resolution (0: no region), before ROMAN's filters."""
        import cv2  # OpenCV and scikit-image are imported on use, not when a configuration loads
        from skimage.segmentation import felzenszwalb

        rgb = np.asarray(frame.rgb)
        depth = np.asarray(frame.depth, dtype=np.float32)
        H, W = depth.shape
        w = min(self.cfg.work_width, W)
        h = max(1, int(round(H * w / W)))
        valid_full = (depth > 0) & (depth <= self.cfg.max_depth_m) & np.isfinite(depth)
        small_rgb = cv2.resize(rgb, (w, h), interpolation=cv2.INTER_AREA) if (h, w) != (H, W) else rgb
        d, valid = _mean_depth(depth, valid_full, (h, w), self.cfg.smooth_px)
        ground = self._ground(frame, d, valid, W / w)
        colour = felzenszwalb(small_rgb, scale=self.cfg.scale, sigma=self.cfg.sigma, min_size=self.cfg.min_size_px)
        regions = self._regions(colour.astype(np.int64), d, valid, ground)
        regions = self._merge(regions, d, ground)
        if (h, w) != (H, W):
            regions = cv2.resize(regions, (W, H), interpolation=cv2.INTER_NEAREST)
        return np.where(valid_full, regions, 0).astype(np.int32)

    def _ground(self, frame: Frame, d: NDArray[np.float32], valid: NDArray[np.bool_], step: float) -> NDArray[np.bool_]:
        """Pixels whose surface normal is within ``ground_normal_deg`` of gravity's up."""
        intr = frame.intrinsics
        h, w = d.shape
        u = (np.arange(w, dtype=np.float32) + 0.5) * step - 0.5
        v = (np.arange(h, dtype=np.float32) + 0.5) * step - 0.5
        x = (u[None, :] - intr.cx) / intr.fx * d
        y = (v[:, None] - intr.cy) / intr.fy * d
        P = np.stack([x, y, d], axis=-1)
        n = np.cross(np.gradient(P, axis=1), np.gradient(P, axis=0))
        norm = np.linalg.norm(n, axis=-1)
        R = (np.asarray(frame.T_odom_body) @ np.asarray(frame.T_body_cam))[:3, :3]
        up_cam = R.T @ np.array([0.0, 0.0, 1.0])
        cos_up = np.abs(n @ up_cam.astype(np.float32)) / np.maximum(norm, 1e-12)
        return valid & (norm > 0) & (cos_up >= np.cos(np.radians(self.cfg.ground_normal_deg)))

    def _continuous(self, da: NDArray[np.float32], db: NDArray[np.float32]) -> NDArray[np.bool_]:
        jump = np.maximum(self.cfg.depth_jump_m, self.cfg.depth_jump_rel * np.minimum(da, db))
        return np.abs(da - db) <= jump

    def _regions(self, colour: NDArray[np.int64], d: NDArray[np.float32], valid: NDArray[np.bool_],
                 ground: NDArray[np.bool_]) -> NDArray[np.int32]:
        """Connected components of the pixel graph of step 3 (1-based; 0 = invalid)."""
        h, w = d.shape
        idx = np.arange(h * w).reshape(h, w)
        rows, cols = [], []
        for a, b in ((np.s_[:, :-1], np.s_[:, 1:]), (np.s_[:-1, :], np.s_[1:, :])):
            keep = (valid[a] & valid[b] & (colour[a] == colour[b]) & (ground[a] == ground[b])
                    & self._continuous(d[a], d[b]))
            rows.append(idx[a][keep])
            cols.append(idx[b][keep])
        r, c = np.concatenate(rows), np.concatenate(cols)
        g = sparse.coo_matrix((np.ones(len(r), dtype=np.int8), (r, c)), shape=(h * w, h * w))
        _, lab = connected_components(g, directed=False)
        out = np.zeros(h * w, dtype=np.int32)
        v = valid.ravel()
        _, dense = np.unique(lab[v], return_inverse=True)
        out[v] = dense.astype(np.int32) + 1
        return out.reshape(h, w)

    def _merge(self, regions: NDArray[np.int32], d: NDArray[np.float32], ground: NDArray[np.bool_]) -> NDArray[np.int32]:
        """Step 4: merge depth-continuous non-ground neighbours, drop ground regions."""
        n = int(regions.max())
        if n == 0:
            return regions
        g_count = np.bincount(regions[ground], minlength=n + 1)
        is_ground = g_count * 2 > np.bincount(regions.ravel(), minlength=n + 1)
        pa, pb, cont = [], [], []
        for a, b in ((np.s_[:, :-1], np.s_[:, 1:]), (np.s_[:-1, :], np.s_[1:, :])):
            ra, rb = regions[a], regions[b]
            sel = (ra != rb) & (ra > 0) & (rb > 0)
            pa.append(np.minimum(ra[sel], rb[sel]))
            pb.append(np.maximum(ra[sel], rb[sel]))
            cont.append(self._continuous(d[a][sel], d[b][sel]))
        a, b, c = np.concatenate(pa), np.concatenate(pb), np.concatenate(cont)
        keep = ~is_ground[a] & ~is_ground[b]
        a, b, c = a[keep], b[keep], c[keep]
        key = a.astype(np.int64) * (n + 1) + b
        uk, inv = np.unique(key, return_inverse=True)
        share = np.bincount(inv, weights=c.astype(np.float64)) / np.bincount(inv)
        join = uk[share >= self.cfg.merge_min_continuous]
        g = sparse.coo_matrix((np.ones(len(join), dtype=np.int8), (join // (n + 1), join % (n + 1))),
                              shape=(n + 1, n + 1))
        _, root = connected_components(g, directed=False)
        root[is_ground] = -1
        root[0] = -1
        _, dense = np.unique(root, return_inverse=True)
        lut = dense.astype(np.int32)  # -1 (label 0 and ground) sorts first and maps to 0
        return lut[regions]


def _mean_depth(depth: NDArray[np.float32], valid: NDArray[np.bool_], shape: tuple[int, int],
                radius: int) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """Depth averaged over valid pixels into ``shape`` and a box of ``radius``; (depth, valid)."""
    import cv2

    h, w = shape
    num = np.where(valid, depth, 0).astype(np.float32)
    den = valid.astype(np.float32)
    if num.shape != (h, w):
        num = cv2.resize(num, (w, h), interpolation=cv2.INTER_AREA)
        den = cv2.resize(den, (w, h), interpolation=cv2.INTER_AREA)
    ok = den >= 0.5
    if radius:
        k = (2 * radius + 1, 2 * radius + 1)
        num = cv2.boxFilter(np.where(ok, num, 0), -1, k, normalize=False)
        den2 = cv2.boxFilter(np.where(ok, den, 0), -1, k, normalize=False)
        return np.where(ok, num / np.maximum(den2, 1e-6), 0).astype(np.float32), ok
    return np.where(ok, num / np.maximum(den, 1e-6), 0).astype(np.float32), ok
