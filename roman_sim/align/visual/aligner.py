"""The ``visual`` method: Kimera-Multi's loop closures between two submaps' keyframes.

Candidate selection (DBoW2 / Kimera-Multi): every keyframe q of submap a scores every
keyframe c of submap b with the L1 score s(q, c); the score is normalised by s(q, q'),
q' being q's previous keyframe in a (the next one for a's first keyframe), and the pair
is a candidate when s(q, c) / s(q, q') > ``alpha``. Queries whose neighbour score is
below ``min_nss_factor`` are skipped (a frame unlike its own neighbour says nothing). The
best ``max_candidates`` candidates by normalised score are verified in 3D
(``verify_pair``); the one with most inliers wins. The estimate between the submaps'
frames is ``T_a_b = T_a_q T_q_c inv(T_b_c)`` with the keyframes' camera poses in their
submaps. ``n_associations`` is the inlier count; ``associations`` are pairs of feature
indices into the two winning keyframes (not segment indices).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.align.base import ALIGNERS, AlignResult
from roman_sim.align.visual.bow import BowVector, score_matrix
from roman_sim.align.visual.verify import VerifyParams, verify_pair
from roman_sim.core.config import StrictModel, validate_model
from roman_sim.geometry import inv_T
from roman_sim.mapping.types import KeyframeSet, Submap


class VisualParams(StrictModel):
    """Kimera-Multi loop-closure settings."""

    alpha: float = Field(0.4, gt=0, description="normalised BoW score threshold for a candidate")
    min_nss_factor: float = Field(0.005, ge=0, description="skip queries scoring below this with their neighbour")
    max_candidates: int = Field(1, ge=1, le=100, description="candidates verified, best normalised score first")
    verify: VerifyParams = Field(default_factory=VerifyParams)


def _bows(kf: KeyframeSet) -> list[BowVector]:
    return [BowVector(*kf.bow(i)) for i in range(len(kf))]


def neighbour_scores(bows: list[BowVector]) -> NDArray[np.float64]:
    """Score of each keyframe against its previous one (the next one for the first); NaN if alone."""
    out = np.full(len(bows), np.nan)
    if len(bows) < 2:
        return out
    S = score_matrix(bows, bows)
    out[1:] = S[np.arange(1, len(bows)), np.arange(len(bows) - 1)]
    out[0] = S[0, 1]
    return out


def candidates(a: KeyframeSet, b: KeyframeSet, p: VisualParams) -> tuple[list[tuple[int, int, float]], float]:
    """Candidate pairs (q in a, c in b, normalised score) above alpha, best first; and the best normalised score."""
    ba, bb = _bows(a), _bows(b)
    nss = neighbour_scores(ba)
    usable = np.isfinite(nss) & (nss >= max(p.min_nss_factor, 1e-12))
    if not usable.any():
        return [], float("nan")
    S = score_matrix(ba, bb)
    N = np.full_like(S, -np.inf)
    N[usable] = S[usable] / nss[usable, None]
    order = np.argsort(-N, axis=None, kind="stable")
    best = float(N.flat[order[0]]) if N.size else float("nan")
    out = []
    for flat in order[: p.max_candidates]:
        q, c = np.unravel_index(flat, N.shape)
        if N[q, c] > p.alpha:
            out.append((int(q), int(c), float(N[q, c])))
    return out, best


class VisualAligner:
    """Bag-of-words place recognition + 3D-3D verification on the submaps' keyframes."""

    name = "visual"

    def __init__(self, **params: Any) -> None:
        self.params = validate_model(VisualParams, params, source=f"aligner {self.name}")

    def align(self, a: Submap, b: Submap) -> AlignResult:
        """Align ``b`` to ``a``: ``T_a_b`` maps b's submap frame into a's."""
        t0 = time.perf_counter()
        for s in (a, b):
            if s.keyframes is None or len(s.keyframes) == 0:
                why = f"submap {s.name} has no keyframes (the visual method needs render_rgb: true)"
                return AlignResult.failure(self.name, why, time.perf_counter() - t0, n_candidates=0)
        ka, kb = a.keyframes, b.keyframes
        assert ka is not None and kb is not None
        cands, best = candidates(ka, kb, self.params)
        info: dict[str, Any] = {"best_normalised_score": best, "n_candidates": len(cands),
                                "association_kind": "keyframe_features"}
        if not cands:
            why = f"no keyframe pair above alpha = {self.params.alpha:g}"
            return AlignResult.failure(self.name, why, time.perf_counter() - t0, **info)
        winner = None
        for q, c, score in cands:
            _, dq, pq = ka.features(q)
            _, dc, pc = kb.features(c)
            out = verify_pair(dq, pq, dc, pc, self.params.verify, (a.name, b.name, q, c))
            if winner is None or len(out.inliers) > len(winner[0].inliers):
                winner = (out, q, c, score)
        assert winner is not None
        out, q, c, score = winner
        info.update({"keyframe_a": q, "keyframe_b": c, "normalised_score": score, "n_matches": out.n_matches})
        T = None
        if out.T_q_c is not None:
            T = ka.T_submap_cam[q] @ out.T_q_c @ inv_T(kb.T_submap_cam[c])
        return AlignResult(self.name, T, out.inliers, np.ones(len(out.inliers)), time.perf_counter() - t0,
                           out.reason, info)


ALIGNERS.register("visual", VisualAligner)
