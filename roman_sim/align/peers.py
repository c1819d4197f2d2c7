"""Baselines on all-to-all centroid correspondences: 3-point RANSAC and KISS-Matcher.

``kiss_matcher`` (MIT-SPARK ROBIN + GNC) is an optional extra (``pip install
roman_sim[peers]``); without it, asking for the method raises a ConfigError saying so.
"""

from __future__ import annotations

import importlib.util
import logging
import time
from typing import Any

import numpy as np
from pydantic import Field

from roman_sim.align.base import ALIGNERS, AlignResult
from roman_sim.align.checks import pair_reason
from roman_sim.align.ransac import RansacParams, one_to_one, ransac_align
from roman_sim.core.config import StrictModel, validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import make_T, transform_points
from roman_sim.mapping.types import Submap

log = logging.getLogger(__name__)


class RansacAlignerParams(RansacParams):
    """RANSAC baseline settings."""

    min_associations_for_transform: int = Field(3, ge=3)


class Ransac1MParams(RansacAlignerParams):
    """RANSAC with one million hypotheses."""

    iterations: int = Field(1_000_000, ge=1, le=100_000_000)


class RansacAligner:
    """3-point RANSAC (``ransac100k``; ``ransac1m`` draws 1M hypotheses)."""

    name = "ransac100k"
    confidence_scores = ("inliers",)
    params_model: type[RansacAlignerParams] = RansacAlignerParams

    def __init__(self, **params: Any) -> None:
        self.params = validate_model(self.params_model, params, source=f"aligner {self.name}")

    def align(self, a: Submap, b: Submap) -> AlignResult:
        """Align ``b`` to ``a``; associations are the best hypothesis' one-to-one inliers."""
        t0 = time.perf_counter()
        why = pair_reason(a, b)
        if why:
            return AlignResult.failure(self.name, why, time.perf_counter() - t0, n_putative=0)
        out = ransac_align(a.centers, b.centers, self.params)
        info = {"n_putative": len(a) * len(b), "n_hypotheses_checked": out.n_checked, "n_inliers": out.n_inliers}
        T, reason = out.T_a_b, out.reason
        if T is not None and len(out.associations) < self.params.min_associations_for_transform:
            T, reason = None, f"only {len(out.associations)} inliers"
        scores = np.ones(len(out.associations))
        res = AlignResult(self.name, T, out.associations, scores, time.perf_counter() - t0, reason, info)
        res.confidence = {"inliers": float(out.n_inliers)}
        return res


class Ransac1MAligner(RansacAligner):
    """RANSAC-1M."""

    name = "ransac1m"
    params_model = Ransac1MParams


class KissMatcherParams(StrictModel):
    """KISS-Matcher settings: its noise bounds scale with ``voxel_size``."""

    # KISS-Matcher scales its ROBIN (x1.0) and GNC (x0.75) noise bounds with voxel_size. On
    # 40 x 40 all-to-all centroid correspondences, 0.3 (its point-cloud default) makes the
    # compatibility graph so dense that no valid solution comes back; 0.1 solved 6/6
    # synthetic pairs with 5 cm centre noise.
    voxel_size: float = Field(0.1, gt=0, description="scale of ROBIN / GNC noise bounds (m)")
    max_corr_dist_m: float = Field(0.5, gt=0, description="inlier distance for the reported associations")
    min_associations_for_transform: int = Field(3, ge=3)


class KissMatcherAligner:
    """KISS-Matcher's ROBIN pruning + GNC solver on all-to-all centroid correspondences."""

    name = "kiss_matcher"
    confidence_scores = ()

    def __init__(self, **params: Any) -> None:
        if importlib.util.find_spec("kiss_matcher") is None:
            raise ConfigError("aligner 'kiss_matcher' needs the optional extra: pip install 'roman_sim[peers]'")
        self.params = validate_model(KissMatcherParams, params, source=f"aligner {self.name}")

    def align(self, a: Submap, b: Submap) -> AlignResult:
        """Align ``b`` to ``a`` (associations: one-to-one pairs within ``max_corr_dist_m``)."""
        import kiss_matcher

        t0 = time.perf_counter()
        why = pair_reason(a, b)
        if why:
            return AlignResult.failure(self.name, why, time.perf_counter() - t0, n_putative=0)
        ia, ib = np.meshgrid(np.arange(len(a)), np.arange(len(b)), indexing="ij")
        src = [x.reshape(3, 1) for x in np.asarray(b.centers, np.float32)[ib.ravel()]]
        dst = [x.reshape(3, 1) for x in np.asarray(a.centers, np.float32)[ia.ravel()]]
        matcher = kiss_matcher.KISSMatcher(kiss_matcher.KISSMatcherConfig(voxel_size=self.params.voxel_size))
        sol = matcher.prune_and_solve(src, dst)
        info = {"n_putative": int(ia.size), "n_rotation_inliers": int(matcher.get_num_rotation_inliers())}
        if not sol.valid:
            why = "kiss_matcher found no valid solution"
            return AlignResult.failure(self.name, why, time.perf_counter() - t0, **info)
        T = make_T(np.asarray(sol.rotation), np.asarray(sol.translation).reshape(3))
        assoc = one_to_one(np.asarray(a.centers), transform_points(T, b.centers), self.params.max_corr_dist_m)
        reason = None
        if len(assoc) < self.params.min_associations_for_transform:
            reason = f"only {len(assoc)} inliers"
        T_a_b = T if reason is None else None
        return AlignResult(self.name, T_a_b, assoc, np.ones(len(assoc)), time.perf_counter() - t0, reason, info)


ALIGNERS.register("ransac100k", RansacAligner)
ALIGNERS.register("ransac1m", Ransac1MAligner)
ALIGNERS.register("kiss_matcher", KissMatcherAligner)
