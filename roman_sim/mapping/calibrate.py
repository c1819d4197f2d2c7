"""Fit the simulated front end to measured grades, so truth-driven runs behave like a real model.

Semantics. The simulated encoder's expected cosines (``semantics.expected_cosine``) are

    same instance, view difference D:  (1 - w_v (1 - cos D)) / (1 + e)
    same family, other instance:       (1 - w_i - w_v) / (1 + e)
    same group, other family:          (1 - w_i - w_v) (c + g) / (1 + e)
    other group:                       (1 - w_i - w_v) c / (1 + e)

with w_i = ``instance_weight``, w_v = ``view_weight``, e = ``noise_energy``, c =
``common_weight``, g = ``group_weight``. A weighted least-squares line of the measured
same-instance mean against (1 - cos D) gives 1 / (1 + e) and w_v / (1 + e); the class means
then give w_i, c and g in closed form. Classes without pairs keep the prior's values; every
value is clipped to its valid range.

Segmentation. The ``fastsam`` error model is fitted by iterating on the same frames: the
simulated segmenter with the current parameters is graded like the target, and each rate
is corrected by the difference of measured rates (miss probabilities by a least-squares
fit of the per-cell miss-rate residuals on the model's features 1, small and far;
over-, under-segmentation and spurious masks multiplicatively), after choosing the boundary
noise (0..4 px) whose mean IoU is closest to the target's.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from roman_sim.mapping.segmenter import SegmenterConfig
from roman_sim.mapping.semantics import SemanticConfig

log = logging.getLogger(__name__)


def _clip(v: float, lo: float = 0.0, hi: float = 1.0) -> float:
    return float(min(max(v, lo), hi))


def _view_line(edges: list[float], means: list[float | None], pairs: list[int]) -> tuple[float, float] | None:
    """(a, b) of mean = a - b (1 - cos D) by weighted least squares; None when D does not vary."""
    mid = np.radians(0.5 * (np.asarray(edges[:-1]) + np.asarray(edges[1:])))
    sel = np.array([m is not None and n > 0 for m, n in zip(means, pairs)])
    if not sel.any():
        return None
    x = 1.0 - np.cos(mid[sel])
    y = np.array([m for m, s in zip(means, sel) if s], dtype=np.float64)
    w = np.sqrt(np.asarray(pairs, dtype=np.float64)[sel])
    if sel.sum() < 2 or np.ptp(x) < 0.05:
        return float(np.average(y, weights=w**2)), float("nan")
    A = np.stack([np.ones_like(x), -x], axis=1) * w[:, None]
    (a, b), *_ = np.linalg.lstsq(A, y * w, rcond=None)
    return float(a), float(b)


def fit_semantics(desc: Any, prior: SemanticConfig | None = None) -> SemanticConfig:
    """``SemanticConfig`` whose expected cosines match measured ``DescriptorGrades`` (or its JSON dict)."""
    prior = prior or SemanticConfig()
    d = desc if isinstance(desc, dict) else desc.to_json()
    means = {k: v["mean"] if v["pairs"] else None for k, v in d["classes"].items()}
    line = _view_line(d["view_edges_deg"], d["view_mean"], d["view_pairs"])
    if line is None:
        log.warning("calibration: no same-instance pairs; the semantic prior is kept")
        return prior.model_copy()
    a, b = line
    a = _clip(a, 1e-3, 1.0)
    noise = _clip(1.0 / a - 1.0, 0.0, 10.0)
    view = prior.view_weight if not np.isfinite(b) else _clip(b / a)
    out = {"noise_energy": noise, "view_weight": view}
    static = 1.0 - prior.instance_weight - view
    if (same_family := means.get("same_family")) is not None:
        inst = _clip(1.0 - view - same_family / a, 0.0, 1.0 - view)
        out["instance_weight"] = inst
        static = 1.0 - inst - view
    if static > 1e-6 and (other_group := means.get("other_group")) is not None:
        out["common_weight"] = _clip(other_group / (a * static))
    common = out.get("common_weight", prior.common_weight)
    if static > 1e-6 and (same_group := means.get("same_group")) is not None:
        out["group_weight"] = _clip(same_group / (a * static) - common, 0.0, 1.0 - common)
    else:
        out["group_weight"] = min(prior.group_weight, 1.0 - common)
    return prior.model_copy(update=out)


#: Grades of a segmenter configuration on the calibration frames: ``grade(cfg) -> SegmentationGrades``.
GradeFn = Callable[[SegmenterConfig], Any]


def _features(cfg: SegmenterConfig, area_edges: list[float], dist_edges: list[float]) -> np.ndarray:
    """(area bins, distance bins, 3) miss-model features 1, small, far at the bin centres."""
    a = np.asarray(area_edges, dtype=np.float64)
    centres_a = 0.5 * (a[:-1] + a[1:])
    small = np.maximum(0.0, 1.0 - centres_a / cfg.small_area_frac)
    d = np.asarray(dist_edges, dtype=np.float64)
    centres_d = np.append(0.5 * (d[:-1] + d[1:]), np.inf)
    far = np.clip((centres_d - cfg.far_start_m) / max(cfg.far_end_m - cfg.far_start_m, 1e-9), 0.0, 1.0)
    f = np.ones((len(small), len(far), 3))
    f[..., 1] = small[:, None]
    f[..., 2] = far[None, :]
    return f


def _rates(g: Any) -> dict[str, Any]:
    obj = np.asarray(g.table_objects, dtype=np.float64)
    det = np.asarray(g.table_detected, dtype=np.float64)
    over = np.asarray(g.table_over, dtype=np.float64).sum()
    return {
        "objects": obj,
        "miss": np.where(obj > 0, 1.0 - det / np.maximum(obj, 1), 0.0),
        "over": over / max(det.sum(), 1.0),
        "under": g.under_segmented / max(g.touching_pairs, 1),
        "spurious": g.spurious / max(g.frames, 1),
        "iou": g.mean_iou or 0.0,
    }


def _ratio_step(value: float, target: float, sim: float, hi: float) -> float:
    if sim > 1e-9:
        return _clip(value * target / sim, 0.0, hi)
    return _clip(value + target, 0.0, hi)


def fit_segmenter(
    target: Any, grade: GradeFn, prior: SegmenterConfig | None = None, iterations: int = 4
) -> SegmenterConfig:
    """``fastsam`` error rates whose grades on the calibration frames match ``target``'s.

    Args:
        target: ``SegmentationGrades`` of the segmenter to imitate.
        grade: grades a simulated segmenter with the given configuration on the same frames.
        prior: starting configuration (default: the ``fastsam`` preset).
        iterations: correction rounds (each grades the simulated segmenter once).
    """
    cfg = (prior or SegmenterConfig()).model_copy()
    want = _rates(target)
    best = min(
        range(5),
        key=lambda px: abs(_rates(grade(cfg.model_copy(update={"boundary_noise_px": px})))["iou"] - want["iou"]),
    )
    cfg = cfg.model_copy(update={"boundary_noise_px": best})
    feats = _features(cfg, target.area_edges_frac, target.distance_edges_m)
    w = np.sqrt(want["objects"]).ravel()
    for it in range(iterations):
        got = _rates(grade(cfg))
        resid = (want["miss"] - got["miss"]).ravel()
        step, *_ = np.linalg.lstsq(feats.reshape(-1, 3) * w[:, None], resid * w, rcond=None)
        upd = {
            "miss_prob": _clip(cfg.miss_prob + step[0]),
            "miss_small_prob": _clip(cfg.miss_small_prob + step[1]),
            "miss_far_prob": _clip(cfg.miss_far_prob + step[2]),
            "oversegment_prob": _ratio_step(cfg.oversegment_prob, want["over"], got["over"], 1.0),
            "undersegment_prob": _ratio_step(cfg.undersegment_prob, want["under"], got["under"], 1.0),
            "spurious_rate": _ratio_step(cfg.spurious_rate, want["spurious"], got["spurious"], 20.0),
        }
        cfg = cfg.model_copy(update=upd)
        log.info("segmenter calibration round %d: %s", it + 1, upd)
    return cfg
