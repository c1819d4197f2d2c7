"""Masks -> 3D observations in the odometry frame (REFERENCE.md section 2).

Each mask is back-projected inside its bounding box with the shared camera model, limited
to ``max_depth_m`` (dropped when fewer than ``min_valid_fraction`` of its pixels are within
range), moved into the odometry frame with the drifted pose, voxel-downsampled, checked
against the plane filter and described by the semantic encoder. Ground truth, when the frame
carries it, only labels the observation (for evaluation) and fills the simulated encoder's
context; an image encoder never sees it. Masks that back-project
to nothing are skipped (logged at debug level), never an error.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import MappingError
from roman_sim.geometry import transform_points
from roman_sim.mapping.segment import pca_extents
from roman_sim.mapping.segmenter import Mask
from roman_sim.mapping.semantics import EncodeContext, SemanticEncoder
from roman_sim.mapping.tracker import MappingConfig, Observation, is_plane_like
from roman_sim.mapping.voxels import downsample
from roman_sim.sensors import Frame, backproject, check_frame

log = logging.getLogger(__name__)


def observe(frame: Frame, masks: list[Mask], cfg: MappingConfig,
            encoder: SemanticEncoder | None) -> list[Observation]:
    """Observations of ``frame`` from its ``masks`` (skipped masks are logged)."""
    check_frame(frame)
    depth = np.asarray(frame.depth, dtype=np.float32)
    T_odom_cam = frame.T_odom_cam
    T_world_cam = None if frame.truth is None else frame.truth.T_world_body @ frame.T_body_cam
    out = []
    for k, m in enumerate(masks):
        if m.pixels.shape != depth.shape:
            raise MappingError(f"frame {frame.index}: mask {k} shape {m.pixels.shape} != depth {depth.shape}")
        obs = _observe_mask(frame, depth, m, cfg, encoder, T_odom_cam, T_world_cam)
        if obs is None:
            log.debug("frame %d: mask %d skipped", frame.index, k)
        else:
            out.append(obs)
    return out


def _observe_mask(frame: Frame, depth: NDArray[np.float32], m: Mask, cfg: MappingConfig,
                  encoder: SemanticEncoder | None, T_odom_cam: NDArray,
                  T_world_cam: NDArray | None) -> Observation | None:
    r0, r1, c0, c1 = m.bbox  # type: ignore[misc]
    pix = m.pixels[r0:r1, c0:c1]
    d = depth[r0:r1, c0:c1]
    total = int(pix.sum())
    sel = pix & (d > 0) & (d <= cfg.max_depth_m) & np.isfinite(d)
    n_sel = int(sel.sum())
    if total == 0 or n_sel < cfg.min_points or n_sel < cfg.min_valid_fraction * total:
        return None
    intr = replace(frame.intrinsics, width=c1 - c0, height=r1 - r0,
                   cx=frame.intrinsics.cx - c0, cy=frame.intrinsics.cy - r0)
    pts_cam = backproject(d, intr, sel)
    pts = downsample(transform_points(T_odom_cam, pts_cam), cfg.voxel)
    if len(pts) < cfg.min_points or is_plane_like(pca_extents(pts), cfg.obs_plane_extents_m):
        return None
    truth: Counter[int] = Counter()
    ctx = EncodeContext()
    if frame.truth is not None and T_world_cam is not None:
        centre_world = transform_points(T_world_cam, pts_cam.mean(axis=0, keepdims=True))[0]
        object_id = None
        if frame.truth.object_ids is not None:  # a real sequence has poses but no instance labels
            ids = np.asarray(frame.truth.object_ids)[r0:r1, c0:c1][sel]
            uniq, counts = np.unique(ids, return_counts=True)
            truth = Counter(dict(zip(uniq.tolist(), counts.tolist())))
            object_id = int(uniq[np.argmax(counts)])
        ctx = EncodeContext(object_id=object_id, view_dir=centre_world - T_world_cam[:3, 3])
    desc = None
    if encoder is not None:
        crop = None if frame.rgb is None else np.asarray(frame.rgb)[r0:r1, c0:c1]
        desc = np.asarray(encoder.encode(crop, pix, ctx), dtype=np.float32)
    return Observation(points=pts, t=float(frame.t), descriptor=desc, truth=truth)
