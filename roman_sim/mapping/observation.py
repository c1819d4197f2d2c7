"""Masks -> 3D observations in the odometry frame.

Each mask is back-projected inside its bounding box with the shared camera model, limited
to ``max_depth_m`` (dropped when fewer than ``min_valid_fraction`` of its pixels are within
range), moved into the odometry frame with the drifted pose, voxel-downsampled, checked
against the plane filter and described by the semantic encoder. Ground truth, when the frame
carries it, only labels the observation (for evaluation) and fills the context of an encoder
that declares ``reads_truth`` (the simulated one); any other encoder never sees it. Masks
that back-project to nothing are skipped (logged at debug level), never an error.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import MappingError
from roman_sim.core.geometry import transform_points
from roman_sim.core.sensors import Frame, backproject, check_frame
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.protocols import EncodeContext, SemanticEncoder, reads_truth
from roman_sim.mapping.segment import pca_extents
from roman_sim.mapping.tracker import MappingConfig, Observation, is_plane_like
from roman_sim.mapping.voxels import downsample

log = logging.getLogger(__name__)


def observe(frame: Frame, masks: list[Mask], cfg: MappingConfig, encoder: SemanticEncoder | None) -> list[Observation]:
    """Observations of ``frame`` from its ``masks`` (skipped masks are logged)."""
    return [obs for _, obs in observe_indexed(frame, masks, cfg, encoder)]


def observe_indexed(
    frame: Frame, masks: list[Mask], cfg: MappingConfig, encoder: SemanticEncoder | None
) -> list[tuple[int, Observation]]:
    """(mask index, observation) of every mask that gives an observation.

    The encoder describes all kept masks of the frame at once when it has ``encode_batch``;
    it gets truth-derived contexts only when it declares ``reads_truth``.
    """
    check_frame(frame)
    depth = np.asarray(frame.depth, dtype=np.float32)
    T_odom_cam = frame.T_odom_cam
    kept: list[tuple[int, _Geometry]] = []
    for k, m in enumerate(masks):
        if m.pixels.shape != depth.shape:
            raise MappingError(f"frame {frame.index}: mask {k} shape {m.pixels.shape} != depth {depth.shape}")
        geo = _geometry(frame, depth, m, cfg, T_odom_cam)
        if geo is None:
            log.debug("frame %d: mask %d skipped", frame.index, k)
        else:
            kept.append((k, geo))
    descs = _describe(frame, [masks[k] for k, _ in kept], [g for _, g in kept], encoder)
    out = []
    for j, (k, geo) in enumerate(kept):
        desc = None if descs is None else descs[j]
        out.append((k, Observation(points=geo.points, t=float(frame.t), descriptor=desc, truth=_labels(frame, geo))))
    return out


@dataclass
class _Geometry:
    """A mask's back-projection: odometry-frame points, camera-frame points, and its window."""

    points: NDArray[np.float64]
    pts_cam: NDArray[np.float64]
    sel: NDArray[np.bool_]
    bbox: tuple[int, int, int, int]
    labels: Counter[int] | None = None  # ``_labels``, once computed


def _geometry(
    frame: Frame, depth: NDArray[np.float32], m: Mask, cfg: MappingConfig, T_odom_cam: NDArray
) -> _Geometry | None:
    r0, r1, c0, c1 = m.bbox  # type: ignore[misc]
    pix = m.pixels[r0:r1, c0:c1]
    d = depth[r0:r1, c0:c1]
    total = int(pix.sum())
    sel = pix & (d > 0) & (d <= cfg.max_depth_m) & np.isfinite(d)
    n_sel = int(sel.sum())
    if total == 0 or n_sel < cfg.min_points or n_sel < cfg.min_valid_fraction * total:
        return None
    intr = replace(
        frame.intrinsics, width=c1 - c0, height=r1 - r0, cx=frame.intrinsics.cx - c0, cy=frame.intrinsics.cy - r0
    )
    pts_cam = backproject(d, intr, sel)
    pts = downsample(transform_points(T_odom_cam, pts_cam), cfg.voxel)
    if len(pts) < cfg.min_points or is_plane_like(pca_extents(pts), cfg.obs_plane_extents_m):
        return None
    return _Geometry(pts, pts_cam, sel, (r0, r1, c0, c1))


def _labels(frame: Frame, geo: _Geometry) -> Counter[int]:
    """Evaluation-only label: true object ids of the observed pixels (empty without instance truth)."""
    if frame.truth is None or frame.truth.object_ids is None:  # a real sequence has poses but no labels
        return Counter()
    if geo.labels is None:
        r0, r1, c0, c1 = geo.bbox
        uniq, counts = np.unique(np.asarray(frame.truth.object_ids)[r0:r1, c0:c1][geo.sel], return_counts=True)
        geo.labels = Counter(dict(zip(uniq.tolist(), counts.tolist())))
    return Counter(geo.labels)


def _truth_context(frame: Frame, geo: _Geometry) -> EncodeContext:
    """What a truth-driven encoder may know: the majority object, each object's pixel share, the view direction."""
    if frame.truth is None:
        return EncodeContext()
    labels = _labels(frame, geo)
    T_world_cam = frame.truth.T_world_body @ frame.T_body_cam
    centre_world = transform_points(T_world_cam, geo.pts_cam.mean(axis=0, keepdims=True))[0]
    object_id = int(max(labels, key=lambda i: (labels[i], -i))) if labels else None
    total = sum(labels.values())
    shares = tuple((int(i), labels[i] / total) for i in sorted(labels)) if total else None
    return EncodeContext(object_id=object_id, view_dir=centre_world - T_world_cam[:3, 3], shares=shares)


def _describe(
    frame: Frame, masks: list[Mask], geos: list[_Geometry], encoder: SemanticEncoder | None
) -> NDArray[np.float32] | None:
    """(N, D) descriptors of the kept masks, or None without an encoder."""
    if encoder is None or not masks:
        return None
    truth = reads_truth(encoder)
    ctxs = [_truth_context(frame, g) if truth else EncodeContext() for g in geos]
    rgb = None if frame.rgb is None else np.asarray(frame.rgb)
    batch = getattr(encoder, "encode_batch", None)
    if callable(batch):
        out = np.asarray(batch(rgb, masks, ctxs), dtype=np.float32)
        if out.ndim != 2 or out.shape[0] != len(masks):
            raise MappingError(
                f"frame {frame.index}: encode_batch returned shape {out.shape} for {len(masks)} masks "
                "(expected (masks, dim))"
            )
        return out
    rows = []
    for m, ctx in zip(masks, ctxs):
        r0, r1, c0, c1 = m.bbox  # type: ignore[misc]
        crop = None if rgb is None else rgb[r0:r1, c0:c1]
        rows.append(np.asarray(encoder.encode(crop, m.pixels[r0:r1, c0:c1], ctx), dtype=np.float32))
    return np.stack(rows)
