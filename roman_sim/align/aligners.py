"""The registry of alignment methods and ``build_aligner``.

``roman`` and its ablations (``clipper``, ``clipper_prune``, ``gravity``,
``semantic_gravity``, ``shape_gravity``) share :class:`RomanAligner` and differ only in the
defaults of their parameter models. RANSAC and KISS-Matcher live in ``peers.py``.
"""

from __future__ import annotations

import logging
import time
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from roman_sim.align.affinity import AffinityParams, build_affinity, cosine_matrix, min_max_ratio, object_scores
from roman_sim.align.base import ALIGNERS, Aligner, AlignResult, Tunable
from roman_sim.align.checks import pair_reason
from roman_sim.align.clipper import ClipperParams, ClipperSolution, solve_clipper
from roman_sim.align.confidence import mean_cosine, percent_associations, rival_objective
from roman_sim.align.registration import estimate_transform, tilt_ok
from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.mapping.types import Submap

log = logging.getLogger(__name__)


class RomanParams(AffinityParams):
    """ROMAN: gravity-decoupled geometry, shape and semantics fused into CLIPPER."""

    min_associations_for_transform: int = Field(3, ge=3, description="fewer selected -> no transform")
    dof: Literal[4, 6] | None = Field(
        None, description="6 = Arun/Kabsch, 4 = yaw + translation; None: 4 with gravity, else 6"
    )
    weighted: bool = Field(False, description="weight the registration by the solver's u")
    max_roll_pitch_deg: float = Field(90.0, gt=0, le=180, description="reject tilted results")
    prune: bool = Field(False, description="drop associations failing the cosine / shape-ratio gates")
    shape_ratio_min: float = Field(0.5, ge=0, le=1, description="per-feature min/max ratio gate when pruning")
    solver: ClipperParams = Field(default_factory=ClipperParams)

    @model_validator(mode="after")
    def _default_dof(self) -> "RomanParams":
        # Submaps are gravity-aligned: a method that trusts gravity estimates yaw + translation
        # only. With 3-5 associations, 6-DoF Arun adds roll/pitch error from centroid noise
        # (measured on the smoke scenario: ROMAN recall 0.19 with 6 DoF, 0.52 with 4 DoF).
        if self.dof is None:
            object.__setattr__(self, "dof", 4 if self.gravity else 6)
        return self


class ClipperBaselineParams(RomanParams):
    """Standard CLIPPER: 3D centroid distances only."""

    gravity: bool = False
    use_shape: bool = False
    use_semantics: bool = False


class ClipperPruneParams(ClipperBaselineParams):
    """CLIPPER on associations pruned by cosine and shape ratio; tilt > 5 deg rejected."""

    prune: bool = True
    max_roll_pitch_deg: float = Field(5.0, gt=0, le=180)


class GravityParams(RomanParams):
    """Ablation: gravity-decoupled geometry only."""

    use_shape: bool = False
    use_semantics: bool = False


class SemanticGravityParams(RomanParams):
    """Ablation: semantics + gravity."""

    use_shape: bool = False


class ShapeGravityParams(RomanParams):
    """Ablation: shape + volume + gravity (no semantics)."""

    use_semantics: bool = False


#: The semantic gate of ROMAN's object score: cosines at or below ``cos_min`` are no association,
#: at or above ``cos_max`` the semantic term is 1 (``roman-sim tune`` may vary both).
SEMANTIC_GATE: dict[str, Tunable] = {
    "cos_min": Tunable(-1.0, 1.0, default=(0.8, 0.85, 0.9), doc="semantic gate: lower cosine bound"),
    "cos_max": Tunable(-1.0, 1.0, doc="semantic gate: upper cosine bound"),
}


class RomanAligner:
    """CLIPPER-based alignment of two submaps; see :class:`RomanParams`."""

    name = "roman"
    params_model: type[RomanParams] = RomanParams
    tunable_params: dict[str, Tunable] = SEMANTIC_GATE
    #: the named scores ``_confidence`` can give (``semantic`` only with semantics or pruning on)
    confidence_scores = ("objective", "density", "percent_associations", "margin", "semantic")

    def __init__(self, **params: Any) -> None:
        self.params = validate_model(self.params_model, params, source=f"aligner {self.name}")

    def candidates(self, a: Submap, b: Submap) -> tuple[NDArray[np.int64], NDArray[np.float64] | None]:
        """Putative associations (P, 2) and their object scores (None when s_o is off)."""
        p = self.params
        keep = np.ones((len(a), len(b)), dtype=bool)
        s_o = None
        if p.use_shape or p.use_semantics:
            s_o = object_scores(a, b, p)
            keep &= s_o > 0
        if p.prune:
            keep &= self._prune_mask(a, b)
        ia, ib = np.nonzero(keep)
        assoc = np.stack([ia, ib], 1).astype(np.int64)
        return assoc, (None if s_o is None else s_o[ia, ib])

    def _prune_mask(self, a: Submap, b: Submap) -> NDArray[np.bool_]:
        p = self.params
        keep = cosine_matrix(a, b) >= p.cos_min
        keep &= min_max_ratio(a.volumes, b.volumes) >= p.shape_ratio_min
        for k in range(3):
            keep &= min_max_ratio(a.shape[:, k], b.shape[:, k]) >= p.shape_ratio_min
        return keep

    def align(self, a: Submap, b: Submap) -> AlignResult:
        """Align ``b`` to ``a``: ``T_a_b`` maps b's centres into a's frame."""
        t0 = time.perf_counter()
        p = self.params
        needs = p.use_semantics or p.prune
        why = pair_reason(a, b, shape=p.use_shape or p.prune, semantics=needs)
        if why:
            return AlignResult.failure(self.name, why, time.perf_counter() - t0, n_putative=0)
        assoc, s_o = self.candidates(a, b)
        if len(assoc) == 0:
            return AlignResult.failure(self.name, "no putative associations", time.perf_counter() - t0, n_putative=0)
        M = build_affinity(a.centers, b.centers, assoc, s_o, p)
        sol = solve_clipper(M, p.solver)
        sel = assoc[sol.selected]
        info = {
            "n_putative": int(len(assoc)),
            "n_edges": int((M.nnz - len(assoc)) // 2),
            "F": sol.F,
            "density": sol.density,
            "iterations": sol.iterations,
        }
        out = self._finish(a, b, sel, sol.u[sol.selected], info, t0)
        out.confidence = self._confidence(a, b, sel, M, sol, semantics=needs)
        out.runtime_s = time.perf_counter() - t0
        return out

    def _confidence(
        self, a: Submap, b: Submap, sel: NDArray[np.int64], M: Any, sol: ClipperSolution, semantics: bool
    ) -> dict[str, float]:
        """ROMAN's named scores of one solved pair (see ``roman_sim.align.confidence``)."""
        rival = rival_objective(M, sol.selected, self.params.solver)
        out = {
            "objective": sol.F,
            "density": sol.density,
            "percent_associations": percent_associations(len(sel), len(a), len(b)),
            "margin": max(0.0, sol.F - rival),
        }
        if semantics and len(sel):
            out["semantic"] = mean_cosine(a.descriptors, b.descriptors, sel)
        return out

    def _finish(self, a: Submap, b: Submap, sel: NDArray[np.int64], u: NDArray, info: dict, t0: float) -> AlignResult:
        p = self.params
        T, why = None, None
        if len(sel) < p.min_associations_for_transform:
            why = f"only {len(sel)} associations (need {p.min_associations_for_transform})"
        else:
            dof = p.dof
            assert dof is not None  # the params' validator resolves None to 4 or 6
            T, why = estimate_transform(b.centers[sel[:, 1]], a.centers[sel[:, 0]], u if p.weighted else None, dof)
            if T is not None and not tilt_ok(T, p.max_roll_pitch_deg):
                T, why = None, f"roll/pitch above {p.max_roll_pitch_deg:g} deg"
        return AlignResult(self.name, T, sel, np.asarray(u, dtype=np.float64), time.perf_counter() - t0, why, info)


def _variant(name: str, model: type[RomanParams], doc: str) -> type[RomanAligner]:
    p = model()
    gate = SEMANTIC_GATE if p.use_semantics else {k: v for k, v in SEMANTIC_GATE.items() if p.prune and k == "cos_min"}
    attrs = {"name": name, "params_model": model, "__doc__": doc, "tunable_params": gate}
    cls = type(f"{name.title().replace('_', '')}Aligner", (RomanAligner,), attrs)
    ALIGNERS.register(name, cls)
    return cls


ALIGNERS.register("roman", RomanAligner)
ClipperAligner = _variant("clipper", ClipperBaselineParams, "Standard CLIPPER on centroid distances.")
ClipperPruneAligner = _variant("clipper_prune", ClipperPruneParams, "CLIPPER with semantic/shape pruning.")
GravityAligner = _variant("gravity", GravityParams, "Ablation: gravity-decoupled geometry only.")
SemanticGravityAligner = _variant("semantic_gravity", SemanticGravityParams, "Ablation: semantics + gravity.")
ShapeGravityAligner = _variant("shape_gravity", ShapeGravityParams, "Ablation: shape + gravity.")


def build_aligner(name: str, params: dict[str, Any] | None = None) -> Aligner:
    """Construct the aligner called ``name`` (or ``package.module:Class``) with ``params``.

    Raises:
        ConfigError: unknown name (the message lists the valid ones), bad parameters, or an
            object without ``name`` and ``align``.
        PluginError: a ``package.module:Class`` that cannot be imported or built, or lacks
            ``name`` and ``align`` (``roman_sim.core.plugins.load_plugin`` also dry-runs it).
    """
    if ":" in name and name not in ALIGNERS:
        from roman_sim.core.plugins import instantiate_plugin

        return instantiate_plugin(name, "aligner", params)  # type: ignore[return-value]
    factory = ALIGNERS.get(name)
    if not callable(factory):
        raise ConfigError(f"aligner {name!r}: not callable")
    try:
        obj = factory(**(params or {}))
    except (TypeError, ValueError) as err:
        raise ConfigError(f"aligner {name!r}: bad parameters: {err}") from None
    if not isinstance(obj, Aligner):
        raise ConfigError(f"aligner {name!r}: object has no 'name' and 'align(a, b)'")
    return obj
