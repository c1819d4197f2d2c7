"""Open-set semantics: a simulated CLIP-like encoder (the ``SemanticEncoder`` of ``mapping.protocols``).

The simulated embedding of one observation of object ``o`` (family ``f``, group ``g``) seen
along the horizontal viewing angle ``phi`` is the unit-normalised sum of unit vectors

    sqrt(c) C + [g] G_g + [f] F_f + [u] U_o + sqrt(v) (cos(phi) A_o + sin(phi) B_o) + [n] N,

with a common vector ``C``, a group, a family and an instance part, a view part that turns
with the viewing angle and observation noise ``N`` (drawn anew for every observation). Each
bracketed part ``[p] P = sqrt(high) P_high + sqrt(low) P_low`` has a full-dimensional
vector (independent draws are nearly orthogonal) and a unit vector in a small subspace
shared by the whole world, which spreads the cosines of two independent draws. The energy
shares come from ``ConfusionConfig.layout`` (``roman_sim.frontend.confusion``), so that the
cosine of two observations has the configured mean and spread for each relation: same
instance (against view difference), same family, same group and other. Groups are
``SemanticConfig.groups`` (a family in no group forms its own). Every vector but the noise
is a function of the world seed and the object, shared by all robots.

``SemanticConfig.view_dependence: false`` holds the view part at one angle (the descriptor
does not change with the viewing direction); ``lighting: false`` leaves out any term for the
sun's direction relative to the view. Only this encoder honours the two switches
(``FrontEndConfig`` refuses them with any other).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError, MappingError
from roman_sim.core.seeding import child_rng
from roman_sim.frontend.confusion import ConfusionConfig, Part
from roman_sim.mapping.protocols import EncodeContext

log = logging.getLogger(__name__)

DEFAULT_GROUPS: dict[str, list[str]] = {
    "tree": ["conifer", "deciduous", "palm", "tree"],
    "shrub": ["bush", "shrub", "hedge"],
    "rock": ["rock", "boulder", "stone"],
    "structure": ["building", "house", "shed", "wall", "fence", "bench", "pole", "lamp", "sign"],
}


#: The simulated encoder's mechanisms that ``SemanticConfig`` can switch off; only the
#: ``simulated`` encoder honours them (an image encoder or a real model has no such term).
SWITCHES = ("view_dependence", "lighting")


class SemanticConfig(StrictModel):
    """The simulated encoder: descriptor dimension, confusion per relation, family groups."""

    dim: int = Field(768, ge=8, le=8192)
    confusion: ConfusionConfig = Field(default_factory=ConfusionConfig)
    groups: dict[str, list[str]] = Field(default_factory=lambda: {k: list(v) for k, v in DEFAULT_GROUPS.items()})
    view_dependence: bool = Field(
        True, description="an instance's descriptor turns with the viewing direction (false: it does not)"
    )
    lighting: bool = Field(True, description="a term for the sun's direction relative to the view (false: none)")

    def switched_off(self) -> list[str]:
        """Names of the simulated mechanisms this configuration switches off (``view_dependence``, ``lighting``)."""
        return [name for name in SWITCHES if not getattr(self, name)]

    def group_of(self, family: str) -> str:
        """Group of ``family`` (a family in no group forms its own)."""
        for g, fams in sorted(self.groups.items()):
            if family in fams:
                return g
        return f"_{family}"

    def group_map(self) -> dict[str, str]:
        """Family -> group for every listed family (as ``group_of``, in one lookup)."""
        out: dict[str, str] = {}
        for g, fams in sorted(self.groups.items()):
            for f in fams:
                out.setdefault(f, g)
        return out


class SimulatedEncoder:
    """CLIP-like embeddings from truth with configurable confusion (see the module docstring).

    Args:
        cfg: descriptor dimension, confusion and groups.
        seed: world-level seed: robots sharing it share every vector but the noise.
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
        self.layout = self.cfg.confusion.layout()
        self._groups = self.cfg.group_map()
        self._rng = child_rng(seed, "semantics", "noise", robot)
        self._bases: dict[str, NDArray[np.float64]] = {}
        self._static: dict[tuple[int, str], NDArray[np.float64]] = {}
        self._views: dict[int, NDArray[np.float64]] = {}
        self._common = self._unit("common")

    def _unit(self, *key: str | int) -> NDArray[np.float64]:
        v = child_rng(self.seed, "semantics", *key).standard_normal(self.cfg.dim)
        return v / np.linalg.norm(v)

    def _basis(self, level: str, dims: int) -> NDArray[np.float64]:
        """(dims, dim) orthonormal rows spanning the world's shared subspace of ``level`` (orthogonal to ``C``)."""
        if level not in self._bases:
            g = child_rng(self.seed, "semantics", "basis", level).standard_normal((self.cfg.dim, dims))
            g -= np.outer(self._common, self._common @ g)
            self._bases[level] = np.linalg.qr(g)[0].T
        return self._bases[level]

    def _off_common(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        """``v`` without its component along the common vector, normalised (no cross term with ``C``)."""
        v = v - (v @ self._common) * self._common
        return v / np.sqrt(v @ v)

    def _part(self, part: Part, level: str, key: str | int) -> NDArray[np.float64]:
        """One part's vector for ``key`` (a group, family or object): full-dimensional plus subspace share."""
        rng = child_rng(self.seed, "semantics", level, key)
        v = np.sqrt(part.high) * self._off_common(rng.standard_normal(self.cfg.dim))
        if part.low > 0:
            z = rng.standard_normal(part.dims)
            v = v + np.sqrt(part.low / (z @ z)) * (z @ self._basis(level, part.dims))
        return v

    def group_of(self, family: str) -> str:
        """Group of ``family`` (``SemanticConfig.group_of``)."""
        return self._groups.get(family, f"_{family}")

    def static(self, oid: int, family: str) -> NDArray[np.float64]:
        """The view- and noise-free part of object ``oid``'s embedding (terrain: ``oid`` -1)."""
        key = (oid, family)
        if key not in self._static:
            lay = self.layout
            self._static[key] = (
                np.sqrt(lay.common) * self._common
                + self._part(lay.group, "group", self.group_of(family))
                + self._part(lay.family, "family", family)
                + self._part(lay.instance, "instance", oid + 1)  # terrain (-1) -> key 0
            )
        return self._static[key]

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
        oid = int(context.object_id if context.object_id is not None else -1)
        phi = 0.0
        if context.view_dir is not None and self.cfg.view_dependence:
            d = np.asarray(context.view_dir, dtype=np.float64).reshape(3)
            if not np.all(np.isfinite(d)):
                raise ConfigError("semantics: view_dir must be finite")
            phi = float(np.arctan2(d[1], d[0]))
        lay = self.layout
        if oid not in self._views:
            ab = child_rng(self.seed, "semantics", "view", oid + 1).standard_normal((2, self.cfg.dim))
            self._views[oid] = np.sqrt(lay.view) * np.stack([self._off_common(ab[0]), self._off_common(ab[1])])
        a, b = self._views[oid]
        v = self.static(oid, self.family_of(context)) + np.cos(phi) * a + np.sin(phi) * b + self._noise()
        return (v / np.sqrt(v @ v)).astype(np.float32)

    def _noise(self) -> NDArray[np.float64]:
        """One observation's noise: a full-dimensional draw plus a unit vector in the noise subspace."""
        n = self.layout.noise
        out = np.zeros(self.cfg.dim)
        if n.high > 0:
            out += np.sqrt(n.high) * self._off_common(self._rng.standard_normal(self.cfg.dim))
        if n.low > 0:
            z = self._rng.standard_normal(n.dims)
            out += np.sqrt(n.low / (z @ z)) * (z @ self._basis("noise", n.dims))
        return out
