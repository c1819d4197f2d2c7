"""A segmenter that sees only pixels: colour regions cut and joined by depth, then ROMAN's filters.

Steps, at a working resolution (``work_width`` columns; the paper ran FastSAM at 256 x 256):

1. Felzenszwalb's graph-based segmentation of the colour image (scikit-image).
2. Depth is averaged over valid pixels (0 < depth <= ``max_depth_m``) and its surface
   normals are compared with gravity (from the odometry pose: VIO observes roll and pitch);
   pixels whose normal is within ``ground_normal_deg`` of up are ground.
3. Two neighbouring pixels stay in one region when they share a colour region, both have
   valid depth, agree on ground / not ground and their depths differ by at most
   ``max(depth_jump_m, depth_jump_rel * depth)`` (connected components, scipy).
4. Non-ground regions of similar chroma whose shared border is mostly depth-continuous are
   merged (one object split by shading); an up-facing region enclosed by one object joins it
   (the object's top); the remaining ground regions and flat, up-facing regions (distant
   ground, where per-pixel normals are noisy) are dropped.
5. Labels go back to full resolution (nearest neighbour, so a region also covers the
   invalid pixels inside its working-resolution cells) and pass ROMAN's mask filters (area
   window, elliptical erosion). Pixels of working cells without valid depth (sky, beyond
   ``max_depth_m``) belong to no mask: such a mask could not be back-projected.

Pixel sizes follow the image: ``min_size_px`` and ``smooth_px`` are given at the working
resolution of ``work_width`` columns, so they are the same share of any image at least that
wide; a narrower image (which is its own working resolution) scales them by its width over
``work_width`` (``min_size_px``, an area, by the square). The final erosion follows the
image width as every mask filter does (``erosion_px`` at 640 px).

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
from roman_sim.core.sensors import Frame
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.mask_filter import MaskFilterConfig, masks_from_labels


class ImageSegmenterConfig(MaskFilterConfig):
    """Parameters of the image segmenter (ROMAN's mask filter fields included).

    ``min_size_px`` and ``smooth_px`` are sizes at ``work_width`` columns, scaled down for a
    narrower image; ``erosion_px`` is at 640 px width, scaled to the image.
    """

    work_width: int = Field(160, ge=16, le=4096, description="columns of the working resolution")
    scale: float = Field(80.0, gt=0, description="Felzenszwalb scale (larger: larger regions)")
    sigma: float = Field(0.5, ge=0, le=5)
    min_size_px: int = Field(12, ge=1, description="smallest colour region at the working resolution")
    max_depth_m: float = Field(7.5, gt=0, le=100)
    depth_jump_m: float = Field(0.25, gt=0, le=10)
    depth_jump_rel: float = Field(0.06, ge=0, le=1)
    smooth_px: int = Field(2, ge=0, le=10, description="radius of the valid-depth box filter")
    ground_normal_deg: float = Field(30.0, ge=0, le=90, description="normals this close to up are ground")
    merge_min_continuous: float = Field(
        0.6,
        ge=0,
        le=1.01,
        description="share of a border that must be depth-continuous to merge two regions (> 1: never merge)",
    )
    cap_border_share: float = Field(
        0.5,
        ge=0,
        le=1.01,
        description="share of a ground region's border an object region must hold to absorb it (an object's top)",
    )
    ground_flat_m: float = Field(
        0.06,
        ge=0,
        le=1,
        description="regions flatter than this (std of their points along an up-facing normal) are ground",
    )
    min_valid_fraction: float = Field(
        0.25,
        ge=0,
        le=1,
        description="regions with a smaller share of valid depth pixels are dropped (they could not be back-projected)",
    )
    merge_max_chroma: float = Field(
        20.0,
        ge=0,
        description="largest distance of mean Lab (a, b) chroma (8-bit units) between two regions that merge",
    )


class ImageSegmenter:
    """Truth-free masks from RGB and depth (see the module docstring)."""

    needs_rgb = True
    reads_truth = False

    def __init__(self, cfg: ImageSegmenterConfig | None = None) -> None:
        self.cfg = cfg or ImageSegmenterConfig()

    def segment(self, frame: Frame) -> list[Mask]:
        """Masks of one frame (``frame.rgb`` required)."""
        if frame.rgb is None:
            raise MappingError(
                f"image segmenter: frame {frame.index} of robot {frame.robot} has no RGB "
                "(set render_rgb: true for this robot)"
            )
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
        h = max(1, round(H * w / W))
        valid_full = (depth > 0) & (depth <= self.cfg.max_depth_m) & np.isfinite(depth)
        small_rgb = cv2.resize(rgb, (w, h), interpolation=cv2.INTER_AREA) if (h, w) != (H, W) else rgb
        shrink = w / self.cfg.work_width  # < 1 only for images narrower than the working resolution
        d, valid = _mean_depth(depth, valid_full, (h, w), int(round(self.cfg.smooth_px * shrink)))
        P = self._points(frame, d, W / w)
        ground, valid = self._ground(frame, P, valid)
        objects = valid & ~ground
        if not objects.any():
            return np.zeros((H, W), dtype=np.int32)
        # Colour regions only in the window of valid non-ground cells (grown by 2): sky, far and
        # ground-only rows cost nothing (ground cells outside keep one colour; they are dropped).
        rows, cols = np.flatnonzero(objects.any(axis=1)), np.flatnonzero(objects.any(axis=0))
        win = np.s_[max(rows[0] - 2, 0) : rows[-1] + 3, max(cols[0] - 2, 0) : cols[-1] + 3]
        colour = np.zeros((h, w), dtype=np.int64)
        colour[win] = felzenszwalb(
            np.ascontiguousarray(small_rgb[win]),
            scale=self.cfg.scale,
            sigma=self.cfg.sigma,
            min_size=max(1, int(round(self.cfg.min_size_px * shrink * shrink))),
        )
        regions = self._regions(colour, d, valid, ground)
        chroma = cv2.cvtColor(np.ascontiguousarray(small_rgb), cv2.COLOR_RGB2LAB)[..., 1:].astype(np.float64)
        regions = self._merge(regions, d, ground, chroma)
        regions = self._drop_flat(regions, P, frame).astype(np.int32)
        f = W // w
        if f * w == W and f * h == H:
            # Nearest-neighbour upsampling by an integer factor repeats each cell in an f x f
            # block, so a region's pixel and valid-pixel counts follow from the cells.
            valid_cells = valid_full.reshape(h, f, w, f).sum(axis=(1, 3)) if f > 1 else valid_full
            regions = _drop_unsupported(regions, valid_cells, self.cfg.min_valid_fraction, f * f)
            return regions if f == 1 else np.repeat(np.repeat(regions, f, axis=0), f, axis=1)
        regions = np.asarray(cv2.resize(regions, (W, H), interpolation=cv2.INTER_NEAREST), dtype=np.int32)
        return _drop_unsupported(regions, valid_full, self.cfg.min_valid_fraction)

    def _points(self, frame: Frame, d: NDArray[np.float32], step: float) -> NDArray[np.float32]:
        """(h, w, 3) camera-frame points of the working cells (cell centres in full-image pixels)."""
        intr = frame.intrinsics
        h, w = d.shape
        u = (np.arange(w, dtype=np.float32) + 0.5) * step - 0.5
        v = (np.arange(h, dtype=np.float32) + 0.5) * step - 0.5
        return np.stack([(u[None, :] - intr.cx) / intr.fx * d, (v[:, None] - intr.cy) / intr.fy * d, d], axis=-1)

    def _ground(
        self, frame: Frame, P: NDArray[np.float32], valid: NDArray[np.bool_]
    ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """(ground, known): cells whose normal is within ``ground_normal_deg`` of up, and cells with a normal.

        Differences use valid neighbours only (central where both exist, else one-sided); a
        cell without a valid neighbour along an axis has no normal (the rim of the valid area).
        """
        du, ok_u = _difference(P, valid, axis=1)
        dv, ok_v = _difference(P, valid, axis=0)
        n = np.cross(du, dv)
        norm = np.linalg.norm(n, axis=-1)
        up_cam = _up_in_camera(frame)
        cos_up = np.abs(n @ up_cam) / np.maximum(norm, 1e-12)
        known = valid & ok_u & ok_v & (norm > 0)
        return known & (cos_up >= np.cos(np.radians(self.cfg.ground_normal_deg))), known

    def _continuous(self, da: NDArray[np.float32], db: NDArray[np.float32]) -> NDArray[np.bool_]:
        jump = np.maximum(self.cfg.depth_jump_m, self.cfg.depth_jump_rel * np.minimum(da, db))
        return np.abs(da - db) <= jump

    def _regions(
        self, colour: NDArray[np.int64], d: NDArray[np.float32], valid: NDArray[np.bool_], ground: NDArray[np.bool_]
    ) -> NDArray[np.int32]:
        """Connected components of the pixel graph of step 3 (1-based; 0 = invalid)."""
        h, w = d.shape
        N = h * w
        # Each cell links to its right (column 0) and lower (column 1) neighbour: the graph is
        # built in CSR form directly (row i holds i + 1 and then i + w), with no sorting.
        grid = np.zeros((h, w, 2), dtype=bool)
        for k, (a, b) in enumerate(((np.s_[:, :-1], np.s_[:, 1:]), (np.s_[:-1, :], np.s_[1:, :]))):
            grid[a + (k,)] = (
                valid[a] & valid[b] & (colour[a] == colour[b]) & (ground[a] == ground[b]) & self._continuous(d[a], d[b])
            )
        link = grid.reshape(N, 2)
        targets = np.stack([np.arange(1, N + 1, dtype=np.int32), np.arange(w, N + w, dtype=np.int32)], axis=1)
        indptr = np.zeros(N + 1, dtype=np.int32)
        np.cumsum(link.sum(axis=1), out=indptr[1:])
        indices = targets[link]
        g = sparse.csr_matrix((np.ones(len(indices)), indices, indptr), shape=(N, N))
        n_comp, lab = connected_components(g, directed=False)
        out = np.zeros(h * w, dtype=np.int32)
        v = valid.ravel()
        out[v] = _dense_ranks(lab[v], n_comp)
        return out.reshape(h, w)

    def _merge(
        self, regions: NDArray[np.int32], d: NDArray[np.float32], ground: NDArray[np.bool_], chroma: NDArray[np.float64]
    ) -> NDArray[np.int32]:
        """Step 4: merge depth-continuous neighbours of similar chroma, drop ground regions.

        Two non-ground regions merge; a ground region merges into a non-ground one only when
        that neighbour holds at least ``cap_border_share`` of its border (the up-facing top
        of an object, enclosed by the object, not the ground it stands on).
        """
        n = int(regions.max())
        if n == 0:
            return regions
        flat = regions.ravel()
        size = np.maximum(np.bincount(flat, minlength=n + 1), 1)
        mean_ab = np.stack(
            [np.bincount(flat, weights=chroma[..., k].ravel(), minlength=n + 1) / size for k in range(2)], axis=1
        )
        is_ground = np.bincount(regions[ground], minlength=n + 1) * 2 > size
        ua, ub, count, share = self._borders(regions, d, n)
        border = np.bincount(ua, weights=count, minlength=n + 1) + np.bincount(ub, weights=count, minlength=n + 1)
        similar = np.linalg.norm(mean_ab[ua] - mean_ab[ub], axis=1) <= self.cfg.merge_max_chroma
        ok = (share >= self.cfg.merge_min_continuous) & similar
        objects = ~is_ground[ua] & ~is_ground[ub]
        cap_a = is_ground[ua] & ~is_ground[ub] & (count >= self.cfg.cap_border_share * border[ua])
        cap_b = is_ground[ub] & ~is_ground[ua] & (count >= self.cfg.cap_border_share * border[ub])
        join = ok & (objects | cap_a | cap_b)
        g = sparse.coo_matrix((np.ones(int(join.sum()), dtype=np.int8), (ua[join], ub[join])), shape=(n + 1, n + 1))
        _, root = connected_components(g, directed=False)
        capped = np.zeros(n + 1, dtype=bool)
        capped[ua[join & cap_a]] = True
        capped[ub[join & cap_b]] = True
        gone = is_ground & ~capped
        gone[0] = True
        # label 0 and dropped ground regions map to 0, the other roots to 1, 2, ... in root order
        dense = np.zeros(n + 1, dtype=np.int32)
        dense[~gone] = _dense_ranks(root[~gone], n + 1)
        return dense[regions]

    def _borders(
        self, regions: NDArray[np.int32], d: NDArray[np.float32], n: int
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Neighbouring region pairs (a < b): labels, border length and its depth-continuous share."""
        pa, pb, cont = [], [], []
        for sa, sb in ((np.s_[:, :-1], np.s_[:, 1:]), (np.s_[:-1, :], np.s_[1:, :])):
            ra, rb = regions[sa], regions[sb]
            sel = (ra != rb) & (ra > 0) & (rb > 0)
            pa.append(np.minimum(ra[sel], rb[sel]))
            pb.append(np.maximum(ra[sel], rb[sel]))
            cont.append(self._continuous(d[sa][sel], d[sb][sel]))
        a, b, c = np.concatenate(pa), np.concatenate(pb), np.concatenate(cont)
        uk, inv = np.unique(a.astype(np.int64) * (n + 1) + b, return_inverse=True)
        count = np.bincount(inv).astype(np.float64)
        share = np.bincount(inv, weights=c.astype(np.float64)) / np.maximum(count, 1)
        return uk // (n + 1), uk % (n + 1), count, share

    def _drop_flat(self, regions: NDArray[np.int32], P: NDArray[np.float32], frame: Frame) -> NDArray[np.int32]:
        """Drop regions whose points lie within ``ground_flat_m`` (std) of a plane facing up.

        Region-level covariances average out the depth noise that makes per-cell normals of
        distant ground unreliable.
        """
        n = int(regions.max())
        if n == 0:
            return regions
        lab = regions.ravel()
        inside = lab > 0  # label 0 is dropped anyway: its cells need no sums
        lab = lab[inside]
        pts = P.reshape(-1, 3)[inside].astype(np.float64)
        cnt = np.maximum(np.bincount(lab, minlength=n + 1), 1).astype(np.float64)
        mean = np.stack([np.bincount(lab, weights=pts[:, k], minlength=n + 1) for k in range(3)], 1) / cnt[:, None]
        cov = np.empty((n + 1, 3, 3))
        for a in range(3):
            for b in range(a, 3):
                m = np.bincount(lab, weights=pts[:, a] * pts[:, b], minlength=n + 1) / cnt - mean[:, a] * mean[:, b]
                cov[:, a, b] = cov[:, b, a] = m
        vals, vecs = np.linalg.eigh(cov)
        up = _up_in_camera(frame).astype(np.float64)
        facing_up = np.abs(vecs[:, :, 0] @ up) >= np.cos(np.radians(self.cfg.ground_normal_deg))
        flat = facing_up & (np.sqrt(np.maximum(vals[:, 0], 0.0)) <= self.cfg.ground_flat_m)
        flat[0] = True
        dense = np.where(flat, 0, np.cumsum(~flat)).astype(np.int32)
        return dense[regions]


def _drop_unsupported(
    regions: NDArray[np.int32], valid: NDArray[np.bool_] | NDArray[np.int64], min_share: float, cell_px: int = 1
) -> NDArray[np.int32]:
    """Regions with less than ``min_share`` of valid depth pixels set to 0.

    ``valid`` holds each cell's number of valid pixels (a boolean image: one pixel per cell)
    and ``cell_px`` the pixels of a cell.
    """
    n = int(regions.max())
    if n == 0 or min_share <= 0:
        return regions
    flat = regions.ravel()
    total = np.bincount(flat, minlength=n + 1) * cell_px
    good = np.bincount(flat, weights=np.asarray(valid).ravel().astype(np.float64), minlength=n + 1)
    keep = good >= min_share * np.maximum(total, 1)
    keep[0] = False
    return np.where(keep[regions], regions, 0).astype(np.int32)


def _dense_ranks(labels: NDArray[np.integer], size: int) -> NDArray[np.int32]:
    """1-based rank of each label among the distinct labels present (labels in [0, size)).

    The same numbers as ``np.unique(labels, return_inverse=True)[1] + 1`` in linear time.
    """
    present = np.zeros(size, dtype=bool)
    present[labels] = True
    return np.cumsum(present, dtype=np.int32)[labels]


def _up_in_camera(frame: Frame) -> NDArray[np.float32]:
    """Gravity's up in the camera frame (from the odometry pose: VIO observes roll and pitch)."""
    R = (np.asarray(frame.T_odom_body) @ np.asarray(frame.T_body_cam))[:3, :3]
    return (R.T @ np.array([0.0, 0.0, 1.0])).astype(np.float32)


def _mean_depth(
    depth: NDArray[np.float32], valid: NDArray[np.bool_], shape: tuple[int, int], radius: int
) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """Mean of the valid depth in each working cell and a box of ``radius`` cells; (depth, valid).

    A cell is valid when some valid pixel lies within ``radius`` cells: this fills the holes
    that sensor noise and the invalidated depth edges leave inside objects.
    """
    import cv2

    h, w = shape
    num = np.where(valid, depth, 0).astype(np.float32)
    den = valid.astype(np.float32)
    if num.shape != (h, w):
        # np.asarray only types OpenCV's result: resize and boxFilter keep the float32 input
        num = np.asarray(cv2.resize(num, (w, h), interpolation=cv2.INTER_AREA), dtype=np.float32)
        den = np.asarray(cv2.resize(den, (w, h), interpolation=cv2.INTER_AREA), dtype=np.float32)
    if radius:
        k = (2 * radius + 1, 2 * radius + 1)
        num = np.asarray(cv2.boxFilter(num, -1, k, normalize=False, borderType=cv2.BORDER_CONSTANT), dtype=np.float32)
        den = np.asarray(cv2.boxFilter(den, -1, k, normalize=False, borderType=cv2.BORDER_CONSTANT), dtype=np.float32)
    ok = den > 1e-3
    return np.where(ok, num / np.maximum(den, 1e-6), 0).astype(np.float32), ok


def _difference(
    P: NDArray[np.float32], valid: NDArray[np.bool_], axis: int
) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """Per-cell difference of ``P`` along ``axis`` from valid neighbours, and where one exists."""
    fwd = np.zeros_like(P)
    ok_f = np.zeros_like(valid)
    sl_a = [slice(None)] * 2
    sl_b = [slice(None)] * 2
    sl_a[axis], sl_b[axis] = slice(0, -1), slice(1, None)
    a, b = tuple(sl_a), tuple(sl_b)
    fwd[a] = P[b] - P[a]
    ok_f[a] = valid[a] & valid[b]
    bwd = np.zeros_like(P)
    ok_b = np.zeros_like(valid)
    bwd[b] = P[b] - P[a]
    ok_b[b] = valid[a] & valid[b]
    both = ok_f & ok_b
    diff = np.where(both[..., None], 0.5 * (fwd + bwd), np.where(ok_f[..., None], fwd, bwd))
    return diff, ok_f | ok_b
