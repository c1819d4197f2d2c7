"""Fit the simulated front end to measured grades, so truth-driven runs behave like a real model.

Semantics. The simulated encoder's confusion (``roman_sim.frontend.confusion``) is the
measured one: a weighted least-squares line of the same-instance mean cosine against
(1 - cos D) over the view-difference bins gives the means from the same and the opposite
side, the pooled within-bin spread the same instance's spread, and each other relation's
mean and spread are the measured ones (the grades' ``other_group`` is ``other``). Classes
without pairs keep the prior's values; figures the model cannot realise are moved to the
nearest it can (``confusion.realisable``; logged). The descriptor dimension is the
measured encoder's.

Segmentation. The ``fastsam`` error model is fitted by iterating on the same frames: the
simulated segmenter with the current parameters is graded like the target, and each rate
is corrected by the difference of measured rates (miss probabilities by a least-squares
fit of the per-cell miss-rate residuals on the model's features 1, small and far, over the
cells within the mapper's depth range;
over-segmentation (the per-frame and the view-dependent split rates by one factor),
under-segmentation per touching pair and spurious masks multiplicatively), after choosing
the boundary noise (0..4 px at 640 px width) whose mean IoU is closest to the target's.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from roman_sim.core.records import to_json
from roman_sim.frontend.appearance import SceneLooks
from roman_sim.frontend.confusion import realisable
from roman_sim.frontend.segmenter import SegmenterConfig
from roman_sim.frontend.semantics import SemanticConfig

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


def _pooled_std(stds: list[float | None], pairs: list[int]) -> float | None:
    """Pooled spread of the same instance's cosine within view-difference bins (None without pairs)."""
    num = sum(n * s * s for s, n in zip(stds, pairs) if s is not None and n > 0)
    den = sum(n for s, n in zip(stds, pairs) if s is not None and n > 0)
    return float(np.sqrt(num / den)) if den else None


def world_shares(
    cfg: SemanticConfig, looks: SceneLooks, same_view: float, family_mean: float, pairs: int = 4000
) -> tuple[float, float, float]:
    """(view share, appearance lift, the lift's variance over pairs) of the world ``looks`` describes,
    for the model's reference figures.

    The configured fall from the same to the opposite side is that of a shape at least
    ``view_reference`` asymmetric, and ``same_family.mean`` that of two instances sharing no
    appearance value; in a world the same instance falls by the mean share
    ``min(1, asymmetry / view_reference)`` of its instances (the view share), and two instances
    of one family sit above ``same_family.mean`` by the mean of ``sqrt(E_a E_b) k(a, b)`` over
    the family's pairs (the lift; ``E`` the appearance energy ``same_view - family_mean`` less
    the instance's view share, ``k`` the appearance kernel; up to ``pairs`` pairs, seeded).
    """
    inst = list(looks.instances.values())
    if not inst:
        return 1.0, 0.0, 0.0
    share = {
        i: (min(1.0, looks.asymmetry[i.shape] / cfg.view_reference) if i.shape in looks.asymmetry else 1.0)
        for i in set(inst)
    }
    view_share = float(np.mean([share[i] for i in inst])) if cfg.view_dependence else 0.0
    by_family: dict[str, list[int]] = {}
    for k, i in enumerate(inst):
        by_family.setdefault(i.family, []).append(k)
    cand = [(a, b) for ks in by_family.values() for n, a in enumerate(ks) for b in ks[n + 1 :]]
    if not cand:
        return max(view_share, 1e-6), 0.0, 0.0
    rng = np.random.default_rng(0)
    pick = rng.choice(len(cand), size=min(pairs, len(cand)), replace=False)
    kern = np.array([cfg.appearance.kernel(inst[cand[j][0]], inst[cand[j][1]]) for j in pick])
    sa = np.array([share[inst[cand[j][0]]] for j in pick])
    sb = np.array([share[inst[cand[j][1]]] for j in pick])
    budget = max(same_view - family_mean, 0.0)  # instance, view and light energies together
    view = 0.5 * (cfg.confusion.same_instance.mean_same_view - cfg.confusion.same_instance.mean_opposite_view)
    if not cfg.view_dependence:
        sa, sb = sa * 0, sb * 0
    ea, eb = np.maximum(budget - view * sa, 0.0), np.maximum(budget - view * sb, 0.0)
    lift = np.sqrt(ea * eb) * kern
    return max(view_share, 1e-6), float(np.mean(lift)), float(np.var(lift))


def fit_semantics(desc: Any, prior: SemanticConfig | None = None, looks: SceneLooks | None = None) -> SemanticConfig:
    """``SemanticConfig`` whose confusion matches measured ``DescriptorGrades`` (or its JSON dict).

    With ``looks`` (how the measured world draws its objects) the measured same-instance fall
    and same-family mean are world figures, and they are taken back to the model's reference
    figures (``world_shares``): the fall divided by the world's view share, the family mean
    less its appearance lift and the family's variance less the lift's (solved with the
    fitted figures, a few fixed-point rounds).
    """
    prior = prior or SemanticConfig()
    d: Any = desc if isinstance(desc, dict) else to_json(desc)  # grades (a higher layer's dataclass) as JSON
    pc = prior.confusion
    line = _view_line(d["view_edges_deg"], d["view_mean"], d["view_pairs"])
    if line is None:
        log.warning("calibration: no same-instance pairs; the semantic prior is kept")
        return prior.model_copy()
    a, b = line
    fall = 0.5 * (pc.same_instance.mean_same_view - pc.same_instance.mean_opposite_view)
    b = fall if not np.isfinite(b) else b
    s_i = _pooled_std(d.get("view_std") or [], d["view_pairs"])
    rel = {}
    for name, key, prior_rel in (
        ("same_family", "same_family", pc.same_family),
        ("same_group", "same_group", pc.same_group),
        ("other", "other_group", pc.other),
    ):
        c = d["classes"].get(key) or {}
        has = bool(c.get("pairs")) and c.get("mean") is not None
        rel[name] = (float(c["mean"]), float(c.get("std") or 0.0)) if has else (prior_rel.mean, prior_rel.std)
    if looks is not None:
        share = world_shares(prior, looks, a, rel["same_family"][0])[0]
        b = b / share if prior.view_dependence else b
        (measured_family, measured_std), family, spread = rel["same_family"], rel["same_family"][0], 0.0
        for _ in range(8):
            trial = realisable(a, a - 2.0 * b, pc.same_instance.std, {**rel, "same_family": (family, 0.0)})[0]
            _, lift, spread = world_shares(prior.model_copy(update={"confusion": trial}), looks, a, family)
            family = measured_family - lift
        rel["same_family"] = (family, float(np.sqrt(max(measured_std**2 - spread, 0.0))))
    conf, notes = realisable(a, a - 2.0 * b, pc.same_instance.std if s_i is None else s_i, rel)
    if notes:
        log.warning(
            "calibration: measured cosines moved to what the simulated encoder can realise: %s", "; ".join(notes)
        )
    dim = d.get("dim") or prior.dim
    return prior.model_copy(update={"confusion": conf, "dim": int(dim)})


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


def _near(g: Any) -> np.ndarray:
    """(distance bins,) the bins within the grades' depth range (all of them without one)."""
    upper = np.array([*g.distance_edges_m[1:], np.inf])
    return upper <= getattr(g, "max_depth_m", np.inf) + 1e-9


def _rates(g: Any) -> dict[str, Any]:
    """Per-cell miss rates, and over-segmentation per detected object within the depth range."""
    obj = np.asarray(g.table_objects, dtype=np.float64)
    det = np.asarray(g.table_detected, dtype=np.float64)
    near = _near(g)
    over = np.asarray(g.table_over, dtype=np.float64)[:, near].sum()
    return {
        "objects": obj,
        "miss": np.where(obj > 0, 1.0 - det / np.maximum(obj, 1), 0.0),
        "over": over / max(det[:, near].sum(), 1.0),
        "under": g.under_segmented / max(g.touching_pairs, 1),
        "spurious": g.spurious / max(g.frames, 1),
        "iou": g.mean_iou_all or 0.0,
    }


def _ratio_step(value: float, target: float, sim: float, hi: float) -> float:
    if sim > 1e-9:
        return _clip(value * target / sim, 0.0, hi)
    return _clip(value + target, 0.0, hi)


def fit_segmenter(
    target: Any, grade: GradeFn, prior: SegmenterConfig | None = None, iterations: int = 4, width: int = 640
) -> SegmenterConfig:
    """``fastsam`` error rates whose grades on the calibration frames match ``target``'s.

    Args:
        target: ``SegmentationGrades`` of the segmenter to imitate.
        grade: grades a simulated segmenter with the given configuration on the same frames.
        prior: starting configuration (default: the ``fastsam`` preset).
        iterations: correction rounds (each grades the simulated segmenter once).
        width: the frames' width (the boundary noise tried is 0..4 px there, given at 640 px).
    """
    cfg = (prior or SegmenterConfig()).model_copy()
    want = _rates(target)
    widths = sorted({min(40, round(k * 640 / max(width, 1))) for k in range(5)})
    best = min(
        widths,
        key=lambda px: abs(_rates(grade(cfg.model_copy(update={"boundary_noise_px": px})))["iou"] - want["iou"]),
    )
    cfg = cfg.model_copy(update={"boundary_noise_px": best})
    feats = _features(cfg, target.area_edges_frac, target.distance_edges_m)
    # Misses are fitted within the mapper's depth range only: beyond it a depth-limited
    # segmenter finds nothing, and those views would drag the far term over the near bins.
    w = (np.sqrt(want["objects"]) * _near(target)[None, :]).ravel()
    for it in range(iterations):
        got = _rates(grade(cfg))
        resid = (want["miss"] - got["miss"]).ravel()
        step, *_ = np.linalg.lstsq(feats.reshape(-1, 3) * w[:, None], resid * w, rcond=None)
        upd = {
            "miss_prob": _clip(cfg.miss_prob + step[0]),
            "miss_small_prob": _clip(cfg.miss_small_prob + step[1]),
            "miss_far_prob": _clip(cfg.miss_far_prob + step[2]),
            "oversegment_prob": _ratio_step(cfg.oversegment_prob, want["over"], got["over"], 1.0),
            "view_split_frac": _ratio_step(cfg.view_split_frac, want["over"], got["over"], 1.0),
            "undersegment_prob": _ratio_step(cfg.undersegment_prob, want["under"], got["under"], 1.0),
            "spurious_rate": _ratio_step(cfg.spurious_rate, want["spurious"], got["spurious"], 20.0),
        }
        cfg = cfg.model_copy(update=upd)
        log.info("segmenter calibration round %d: %s", it + 1, upd)
    return cfg
