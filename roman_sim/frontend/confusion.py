"""How much the simulated encoder confuses objects: one cosine distribution per relation.

Two observations of objects are related as the same instance (seen ``D`` degrees apart),
the same family (two instances of one family), the same group (two families of one group,
e.g. conifer and deciduous) or other. ``ConfusionConfig`` gives each relation's mean cosine
and spread; the same instance's mean falls linearly in (1 - cos D) from ``mean_same_view``
to ``mean_opposite_view``. ``level`` multiplies every spread (0: the classes never overlap;
1: the configured spreads), so ``frontend.semantics.confusion`` can be swept as one number
(a bare number is read as ``{level: number}``).

``layout`` turns the figures into the energy shares of the embedding's parts (see
``roman_sim.frontend.semantics``): a common part (share ``other.mean``), a group part
(``same_group.mean - other.mean``), a family part (``same_family.mean - same_group.mean``),
an instance part (the same instance's mean over views minus ``same_family.mean``), a view
part (half the same instance's fall from 0 to 180 deg) and observation noise (1 -
``mean_same_view``). A part's spread comes from the share of it drawn in a small subspace
shared by the whole world: there, two random unit vectors of k dimensions have a cosine of
mean 0 and variance 1/k, so a part with low-dimensional energy ``w`` adds w^2/k to the
variance of every relation whose pairs draw it independently. Hence the variances add up
from the narrowest relation to the broadest:

    same instance:  s_i^2 = n^2/k_n                   (observation noise)
    same family:    s_f^2 = s_i^2 + u^2/k_u          (instance part)
    same group:     s_g^2 = s_f^2 + f^2/k_f          (family part)
    other:          s_o^2 = s_g^2 + g^2/k_g          (group part)

so spreads must not shrink from the same instance to other, and each increment is bounded
by its part's share (k >= 3, so each part's cosines are spread over [-1, 1] rather than
bunched at its ends): what a part does not need in its subspace stays in full-dimensional,
nearly orthogonal directions that only move the means.

The simulated encoder splits the instance and view shares per instance
(``roman_sim.frontend.semantics``): ``same_family`` describes two instances that share no
appearance value (kernel 0), and the same instance's fall is that of a shape at least
``view_reference`` asymmetric; instances drawn alike sit above ``same_family.mean`` by their
appearance kernel times their appearance energy, and more symmetric shapes fall less.

Defaults (CLIP ViT-L/14 on object crops, as ROMAN uses it): CLIP gives 0.8-0.9 for two
different photos of one class and about 0.5 for unrelated photos; near-duplicates sit at
0.95-0.99; ROMAN's semantic gate (0.85 / 1.0) passes most views of one object from one side
and few of other objects. Sources and the measured built-in image encoder are in
``docs/mapping.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pydantic import Field, model_validator

from roman_sim.core.config import StrictModel

#: Fewest dimensions of a part's shared subspace; most (beyond it the part is nearly Gaussian).
MIN_DIMS, MAX_DIMS = 3, 32


class SameInstanceCosine(StrictModel):
    """Two observations of one object: mean cosine from the same and the opposite side, and spread."""

    mean_same_view: float = Field(0.92, ge=-1, le=1)
    mean_opposite_view: float = Field(0.80, ge=-1, le=1)
    std: float = Field(0.035, ge=0, le=1)


class RelationCosine(StrictModel):
    """Mean cosine and spread of one relation between two different objects."""

    mean: float = Field(..., ge=-1, le=1)
    std: float = Field(..., ge=0, le=1)


@dataclass(frozen=True)
class Part:
    """One part of the embedding: total energy share, its share in the shared subspace, that subspace's dimension."""

    weight: float
    low: float
    dims: int

    @property
    def high(self) -> float:
        """Energy share in full-dimensional (nearly orthogonal) directions."""
        return max(0.0, self.weight - self.low)


@dataclass(frozen=True)
class Layout:
    """Energy shares of the simulated embedding (they sum to 1)."""

    common: float
    group: Part
    family: Part
    instance: Part
    view: float
    noise: Part


class ConfusionConfig(StrictModel):
    """Cosine distribution per relation (``frontend.semantics.confusion``; see the module docstring)."""

    level: float = Field(1.0, ge=0, le=10, description="multiplies every spread (0: classes never overlap)")
    same_instance: SameInstanceCosine = Field(default_factory=SameInstanceCosine)
    same_family: RelationCosine = Field(default_factory=lambda: RelationCosine(mean=0.80, std=0.04))
    same_group: RelationCosine = Field(default_factory=lambda: RelationCosine(mean=0.72, std=0.05))
    other: RelationCosine = Field(default_factory=lambda: RelationCosine(mean=0.58, std=0.07))

    @model_validator(mode="before")
    @classmethod
    def _bare_level(cls, v: Any) -> Any:
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            return {"level": v}
        return v

    @model_validator(mode="after")
    def _realisable(self) -> ConfusionConfig:
        if _ok(self, self.level):
            return self
        base = self.model_copy(update={"level": 1.0})
        if self.level != 1.0 and _ok(base, 1.0):
            raise ValueError(
                f"level ({self.level:g}) is too large for these means and spreads: at most {self.max_level():.3g}"
            )
        base.layout()  # raises the message naming the field
        return self

    def spreads(self) -> tuple[float, float, float, float]:
        """(same instance, same family, same group, other) spreads at this ``level``."""
        k = self.level
        return (
            k * self.same_instance.std,
            k * self.same_family.std,
            k * self.same_group.std,
            k * self.other.std,
        )

    def layout(self) -> Layout:
        """The embedding's energy shares; ``ValueError`` naming the field when the figures cannot be realised."""
        si = self.same_instance
        m0, m180 = si.mean_same_view, si.mean_opposite_view
        if m180 > m0:
            raise ValueError(f"same_instance.mean_opposite_view ({m180:g}) must not exceed mean_same_view ({m0:g})")
        mid = 0.5 * (m0 + m180)
        means = [("same_family", self.same_family.mean, "the same instance's mean over views", mid)]
        means += [("same_group", self.same_group.mean, "same_family.mean", self.same_family.mean)]
        means += [("other", self.other.mean, "same_group.mean", self.same_group.mean)]
        for name, m, what, bound in means:
            if m > bound + 1e-12:
                raise ValueError(f"{name}.mean ({m:g}) must not exceed {what} ({bound:g})")
        if self.other.mean < 0:
            raise ValueError(f"other.mean ({self.other.mean:g}) must be at least 0 (a common part cannot be negative)")
        s_i, s_f, s_g, s_o = self.spreads()
        noise = _part("same_instance.std", s_i, s_i**2, 1.0 - m0, "1 - mean_same_view", None)
        parts = []
        for name, (narrow, s_narrow), s, w, what in (
            ("same_family", ("same_instance", s_i), s_f, mid - self.same_family.mean, "the instance share"),
            ("same_group", ("same_family", s_f), s_g, self.same_family.mean - self.same_group.mean, "the family share"),
            ("other", ("same_group", s_g), s_o, self.same_group.mean - self.other.mean, "the group share"),
        ):
            if s < s_narrow - 1e-12:
                raise ValueError(
                    f"{name}.std ({s / max(self.level, 1e-12):g}) must be at least {narrow}.std "
                    f"({s_narrow / max(self.level, 1e-12):g}): a broader relation's spread includes the narrower one's"
                )
            bound = math.sqrt(s_narrow**2 + w * w / MIN_DIMS)
            parts.append(_part(f"{name}.std", s, s * s - s_narrow**2, w, what, bound))
        instance, family, group = parts
        return Layout(self.other.mean, group, family, instance, 0.5 * (m0 - m180), noise)

    def max_level(self) -> float:
        """The largest ``level`` these means and spreads can be realised at (inf when every spread is 0)."""
        base = self.model_copy(update={"level": 1.0})
        if not any(base.spreads()):
            return math.inf
        lo, hi = 0.0, 1.0
        while _ok(base, hi) and hi < 1e3:
            lo, hi = hi, 2 * hi
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if _ok(base, mid) else (lo, mid)
        return lo


def _ok(base: ConfusionConfig, level: float) -> bool:
    try:
        base.model_copy(update={"level": level}).layout()
    except ValueError:
        return False
    return True


def _part(field: str, std: float, var: float, weight: float, what: str, bound: float | None) -> Part:
    """The part of energy ``weight`` whose low-dimensional share gives variance ``var`` (spread ``std``)."""
    var = max(var, 0.0)
    if var == 0.0:
        return Part(weight, 0.0, MIN_DIMS)
    if weight <= 0 or weight * weight / var < MIN_DIMS - 1e-9:
        limit = math.sqrt(max(weight, 0.0) ** 2 / MIN_DIMS) if bound is None else bound
        raise ValueError(
            f"{field} ({std:g}) is too large for the means: at most {limit:.3g} "
            f"(its spread comes from {what}, {max(weight, 0.0):.3g})"
        )
    dims = int(min(MAX_DIMS, max(MIN_DIMS, math.floor(weight * weight / var + 1e-9))))
    return Part(weight, math.sqrt(var * dims), dims)


def relation_moments(cfg: ConfusionConfig, view_diff_rad: float = 0.0) -> dict[str, tuple[float, float]]:
    """(mean, spread) of every relation's cosine; the same instance's at view difference ``view_diff_rad``."""
    si = cfg.same_instance
    s_i, s_f, s_g, s_o = cfg.spreads()
    view = 0.5 * (si.mean_same_view - si.mean_opposite_view)
    return {
        "same_instance": (si.mean_same_view - view * (1.0 - math.cos(view_diff_rad)), s_i),
        "same_family": (cfg.same_family.mean, s_f),
        "same_group": (cfg.same_group.mean, s_g),
        "other": (cfg.other.mean, s_o),
    }


def realisable(
    same_view: float,
    opposite_view: float,
    instance_std: float,
    relations: dict[str, tuple[float, float]],
) -> tuple[ConfusionConfig, list[str]]:
    """The nearest realisable ``ConfusionConfig`` to measured figures, and what had to change.

    ``relations`` maps ``same_family``, ``same_group`` and ``other`` to (mean, spread).
    Means are clipped into their order (other <= same group <= same family <= the same
    instance over views, other >= 0) and spreads raised to the narrower relation's, then
    lowered to what each part's share allows (at 0.999 of the bound).
    """
    notes: list[str] = []

    def clip(name: str, v: float, lo: float, hi: float) -> float:
        out = min(max(v, lo), hi)
        if abs(out - v) > 1e-12:
            notes.append(f"{name} {v:.3f} -> {out:.3f}")
        return out

    m0 = clip("same_instance.mean_same_view", same_view, -1.0, 1.0)
    m180 = clip("same_instance.mean_opposite_view", opposite_view, -1.0, m0)
    mid = 0.5 * (m0 + m180)
    means, bound = {}, mid
    for name in ("same_family", "same_group", "other"):
        bound = means[name] = clip(f"{name}.mean", relations[name][0], 0.0, max(bound, 0.0))
    s_prev = clip("same_instance.std", instance_std, 0.0, 0.999 * (1.0 - m0) / math.sqrt(MIN_DIMS))
    stds = {"same_instance": s_prev}
    shares = {
        "same_family": mid - means["same_family"],
        "same_group": means["same_family"] - means["same_group"],
        "other": means["same_group"] - means["other"],
    }
    for name in ("same_family", "same_group", "other"):
        hi = math.sqrt(s_prev**2 + 0.998 * shares[name] ** 2 / MIN_DIMS)
        s_prev = stds[name] = clip(f"{name}.std", relations[name][1], s_prev, hi)
    cfg = ConfusionConfig(
        same_instance=SameInstanceCosine(mean_same_view=m0, mean_opposite_view=m180, std=stds["same_instance"]),
        **{k: RelationCosine(mean=means[k], std=stds[k]) for k in means},
    )
    return cfg, notes
