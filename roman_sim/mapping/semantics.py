"""Open-set semantics: the ``SemanticEncoder`` protocol and a simulated CLIP-like encoder.

The simulated embedding of one observation of object ``o`` (family ``f``) seen along the
horizontal viewing angle ``phi`` is the unit-normalised sum

    sqrt(1 - w_i - w_v) * p_f  +  sqrt(w_i) * u_o  +  sqrt(w_v) * (cos(phi) a_o + sin(phi) b_o)  +  n,

with unit family prototype ``p_f``, unit instance vector ``u_o``, unit view vectors ``a_o``,
``b_o`` and white noise ``n`` of total energy ``noise_energy``. Prototypes share a common
part (all families) and a group part (families of one group, e.g. trees), so
cos(p_f, p_g) = ``common_weight`` (+ ``group_weight`` within a group). In high dimension,
independent random parts are nearly orthogonal, which gives the expected cosines of
``expected_cosine``. Defaults: same view ~0.94, 90 deg ~0.87, opposite ~0.79 (CLIP
threshold 0.85), another instance of the family ~0.82.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError, MappingError
from roman_sim.core.seeding import child_rng

log = logging.getLogger(__name__)

DEFAULT_GROUPS: dict[str, list[str]] = {
    "tree": ["conifer", "deciduous", "palm", "tree"],
    "shrub": ["bush", "shrub", "hedge"],
    "rock": ["rock", "boulder", "stone"],
    "structure": ["building", "house", "shed", "wall", "fence", "bench", "pole", "lamp", "sign"],
}


@dataclass
class EncodeContext:
    """What a simulated encoder may know about an observation (a real model ignores it).

    Attributes:
        object_id: true majority object id under the mask (-1 for terrain), or None when
            the frame carries no ground truth (a truth-driven encoder cannot run then).
        family: family name; looked up from ``object_id`` when None.
        view_dir: (3,) viewing direction camera -> object in the world frame, or None.
    """

    object_id: int | None = None
    family: str | None = None
    view_dir: NDArray[np.float64] | None = None


@runtime_checkable
class SemanticEncoder(Protocol):
    """Image crop + mask -> unit float32 descriptor (CLIP, DINO, or a simulation)."""

    def encode(
        self, rgb_crop: NDArray[np.uint8] | None, mask: NDArray[np.bool_], context: EncodeContext
    ) -> NDArray[np.float32]:
        """Unit descriptor of one masked observation."""
        ...


class SemanticConfig(StrictModel):
    """Similarity structure of the simulated encoder (weights are squared-norm shares)."""

    dim: int = Field(768, ge=8, le=8192)
    common_weight: float = Field(0.3, ge=0, le=1)
    group_weight: float = Field(0.4, ge=0, le=1)
    instance_weight: float = Field(0.05, ge=0, le=1)
    view_weight: float = Field(0.08, ge=0, le=1)
    noise_energy: float = Field(0.06, ge=0, le=10)
    groups: dict[str, list[str]] = Field(default_factory=lambda: {k: list(v) for k, v in DEFAULT_GROUPS.items()})

    @model_validator(mode="after")
    def _check_weights(self) -> "SemanticConfig":
        if self.common_weight + self.group_weight > 1:
            raise ValueError("common_weight + group_weight must be <= 1")
        if self.instance_weight + self.view_weight > 1:
            raise ValueError("instance_weight + view_weight must be <= 1")
        return self

    def group_of(self, family: str) -> str:
        """Group of ``family`` (a family in no group forms its own)."""
        for g, fams in sorted(self.groups.items()):
            if family in fams:
                return g
        return f"_{family}"


def expected_cosine(
    cfg: SemanticConfig, same_instance: bool, view_diff_rad: float = 0.0, family_cos: float = 1.0
) -> float:
    """High-dimensional expectation of the cosine between two simulated embeddings.

    Args:
        same_instance: both observations of the same object.
        view_diff_rad: difference of viewing angles (same instance only).
        family_cos: cosine of the two family prototypes (1 for the same family).
    """
    static = 1.0 - cfg.instance_weight - cfg.view_weight
    if same_instance:
        num = static + cfg.instance_weight + cfg.view_weight * np.cos(view_diff_rad)
    else:
        num = static * family_cos
    return float(num / (1.0 + cfg.noise_energy))


def family_cosine(cfg: SemanticConfig, fam_a: str, fam_b: str) -> float:
    """Configured cosine of two family prototypes."""
    if fam_a == fam_b:
        return 1.0
    same_group = cfg.group_of(fam_a) == cfg.group_of(fam_b)
    return cfg.common_weight + (cfg.group_weight if same_group else 0.0)


class SimulatedEncoder:
    """CLIP-like embeddings from truth: family prototypes, instance and view terms, noise.

    Args:
        cfg: similarity structure.
        seed: world-level seed: robots sharing it share prototypes and instance vectors.
        families: object id -> family name (from ``WorldTruth``).
        robot: name keying this robot's independent observation-noise stream.
    """

    needs_rgb = False
    reads_truth = True

    def __init__(
        self,
        cfg: SemanticConfig | None = None,
        seed: int = 0,
        families: Mapping[int, str] | None = None,
        robot: str = "",
    ) -> None:
        self.cfg = cfg or SemanticConfig()
        self.seed = seed
        self.families = dict(families or {})
        self._rng = child_rng(seed, "semantics", "noise", robot)
        self._cache: dict[tuple, NDArray[np.float64]] = {}

    def _unit(self, *key: str | int) -> NDArray[np.float64]:
        if key not in self._cache:
            v = child_rng(self.seed, "semantics", *key).standard_normal(self.cfg.dim)
            self._cache[key] = v / np.linalg.norm(v)
        return self._cache[key]

    def prototype(self, family: str) -> NDArray[np.float64]:
        """Unit prototype of ``family``."""
        c = self.cfg
        own = max(0.0, 1.0 - c.common_weight - c.group_weight)
        v = (
            np.sqrt(c.common_weight) * self._unit("common")
            + np.sqrt(c.group_weight) * self._unit("group", c.group_of(family))
            + np.sqrt(own) * self._unit("family", family)
        )
        return v / np.linalg.norm(v)

    def family_of(self, context: EncodeContext) -> str:
        """Family of the observed object (``terrain`` for background)."""
        if context.family is not None:
            return context.family
        if context.object_id is None or context.object_id < 0:
            return "terrain"
        return self.families.get(int(context.object_id), "unknown")

    def encode(
        self, rgb_crop: NDArray[np.uint8] | None, mask: NDArray[np.bool_], context: EncodeContext
    ) -> NDArray[np.float32]:
        """Unit float32 embedding (``rgb_crop`` and ``mask`` are not used by the model)."""
        if context.object_id is None and context.family is None:
            raise MappingError(
                "the simulated encoder builds descriptors from ground truth: this frame has none "
                "(use an image encoder for real or truth-free frames)"
            )
        c = self.cfg
        oid = int(context.object_id if context.object_id is not None else -1) + 1  # terrain (-1) -> key 0
        phi = 0.0
        if context.view_dir is not None:
            d = np.asarray(context.view_dir, dtype=np.float64).reshape(3)
            if not np.all(np.isfinite(d)):
                raise ConfigError("semantics: view_dir must be finite")
            phi = float(np.arctan2(d[1], d[0]))
        static = max(0.0, 1.0 - c.instance_weight - c.view_weight)
        v = (
            np.sqrt(static) * self.prototype(self.family_of(context))
            + np.sqrt(c.instance_weight) * self._unit("instance", oid)
            + np.sqrt(c.view_weight)
            * (np.cos(phi) * self._unit("view_a", oid) + np.sin(phi) * self._unit("view_b", oid))
            + self._rng.standard_normal(c.dim) * np.sqrt(c.noise_energy / c.dim)
        )
        return (v / np.linalg.norm(v)).astype(np.float32)
