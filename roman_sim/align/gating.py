"""Submap gating: register only the candidate pairs whose submap descriptors are similar.

As a real-time system does before registration, each submap gets one global descriptor
and only promising pairs are handed to the aligners, so the alignment cost grows with the
number of candidates kept rather than with all pairs. The descriptor of a submap
concatenates, each block L2-normalised and weighted:

* ``semantic``: the mean of its segments' unit semantic descriptors (what is there);
* ``size``: a histogram of log10 segment volume, 8 bins over 1e-3 .. 1e3 m^3 (how big);
* ``shape``: the mean PCA linearity, planarity and scattering (what form).

Similarity is the cosine of two descriptors. A pair is kept when its similarity is at
least ``min_similarity`` or when it is among the ``top_k`` most similar candidates of
either of its submaps. Gated-out pairs count as "no alignment" in the evaluation, so the
recall shows what gating loses. Off by default.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.mapping.types import Submap

log = logging.getLogger(__name__)

GATED_REASON = "gated out: submap descriptors not similar enough"
_VOLUME_EDGES = np.linspace(-3.0, 3.0, 9)


class GatingConfig(StrictModel):
    """Which candidate pairs are registered (all of them unless ``enabled``)."""

    enabled: bool = False
    top_k: int | None = Field(8, ge=1, le=10000, description="keep each submap's k most similar candidates")
    min_similarity: float | None = Field(None, ge=-1.0, le=1.0, description="keep pairs at least this similar")
    semantic_weight: float = Field(1.0, ge=0.0, le=10.0)
    size_weight: float = Field(1.0, ge=0.0, le=10.0)
    shape_weight: float = Field(0.5, ge=0.0, le=10.0)


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    n = float(np.linalg.norm(v))
    return v / n if n > 0 else v


def submap_descriptor(s: Submap, cfg: GatingConfig, dim: int | None = None) -> NDArray[np.float64]:
    """The unit global descriptor of ``s``; zeros for an empty submap (``dim``: semantic dimension)."""
    n = len(s.segment_ids)
    if n == 0:
        dim = dim if dim is not None else (s.descriptors.shape[1] if s.descriptors.ndim == 2 else 0)
        return np.zeros(dim + len(_VOLUME_EDGES) - 1 + 3)
    sem = _unit(np.asarray(s.descriptors, dtype=np.float64).mean(axis=0))
    logv = np.log10(np.clip(np.asarray(s.volumes, dtype=np.float64), 1e-3, 1e3))
    size = _unit(np.histogram(logv, bins=_VOLUME_EDGES)[0].astype(np.float64))
    shape = _unit(np.asarray(s.shape, dtype=np.float64).mean(axis=0))
    return _unit(np.concatenate([cfg.semantic_weight * sem, cfg.size_weight * size, cfg.shape_weight * shape]))


def gate_pairs(pairs: list[tuple[Submap, Submap]], cfg: GatingConfig) -> tuple[list[bool], list[float]]:
    """Per pair: whether it is registered, and its descriptor similarity (NaN when gating is off)."""
    if not cfg.enabled:
        return [True] * len(pairs), [float("nan")] * len(pairs)
    names = sorted({s.name for ab in pairs for s in ab})
    subs = {s.name: s for ab in pairs for s in ab}
    dim = max(
        (subs[n].descriptors.shape[1] for n in names if subs[n].descriptors.ndim == 2 and len(subs[n].segment_ids)),
        default=0,
    )
    desc = {n: submap_descriptor(subs[n], cfg, dim) for n in names}
    sims = [float(np.dot(desc[a.name], desc[b.name])) for a, b in pairs]
    keep = [cfg.min_similarity is not None and s >= cfg.min_similarity for s in sims]
    if cfg.top_k is not None:
        by_submap: dict[str, list[int]] = {}
        for i, (a, b) in enumerate(pairs):
            by_submap.setdefault(a.name, []).append(i)
            by_submap.setdefault(b.name, []).append(i)
        for idx in by_submap.values():
            for i in sorted(idx, key=lambda i: (-sims[i], i))[: cfg.top_k]:
                keep[i] = True
    log.info("submap gating: %d of %d pairs kept", sum(keep), len(pairs))
    return keep, sims
