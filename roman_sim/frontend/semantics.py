"""Open-set semantics: a simulated CLIP-like encoder (the ``SemanticEncoder`` of ``mapping.protocols``).

The simulated embedding of one observation of object ``o`` (family ``f``, group ``g``, drawn
by the renderer with appearance values ``x_o``: ``roman_sim.frontend.appearance``) seen along
the horizontal viewing angle ``phi`` is the unit-normalised sum

    sqrt(c) C + [g] G_g + [f] F_f + [E_o] a(x_o) + sqrt(v_s) (cos(psi) A_s + sin(psi) B_s)
      + sqrt(l) (cos(beta) P_s + sin(beta) Q_s) + [n] N,

with a common vector ``C``, a group and a family part, an appearance part, a view part, a
light part and observation noise ``N`` (drawn anew for every observation). Nothing is drawn
per object: the appearance part is the feature vector of the object's appearance VALUES
(shape variant, scale, part colours, texture regions), so two instances the renderer draws
alike get the same vector, and the view and light vectors ``A_s, B_s, P_s, Q_s`` are keyed by
the family and shape variant ``s``. ``psi`` is the viewing azimuth in the object's own frame
(``phi`` less its heading); ``beta`` the angle between the view and the sun's azimuth (0:
against the sun, pi: the sun behind the camera).

Energies: ``c``, the group, family and noise shares come from ``ConfusionConfig.layout``
(``roman_sim.frontend.confusion``); of the same instance's view energy ``V`` (half its fall
from the same to the opposite side), the light takes ``l = min(lighting_fall / 2 * strength, V)``
(``strength``: the sun's share of the light times the cosine of its elevation,
``SceneLight.strength``; the configured fall bounds the light and the view together) and the
view ``v_s = (V - l) min(1, d_s / view_reference)``, with ``d_s`` the shape's front-back
asymmetry (``roman_sim.frontend.view_asymmetry``); the appearance part takes the rest,
``E_o = U + V - l - v_s`` (``U``: the layout's instance share). Two observations of one
instance from one side therefore keep ``mean_same_view``; from opposite sides the view part
falls by ``2 v_s`` (``2 (V - l)`` for a shape at least ``view_reference`` asymmetric, nothing
for a conifer, ``d = 0``) and the light part by ``l (1 + cos 2x)``, ``x`` the angle between
the view and the sun's azimuth (``2 l`` along the sun's line, nothing across it);
two instances of one family sit at ``same_family.mean`` plus ``E`` times their appearance
kernel (``AppearanceModel.kernel``): ``same_family.mean`` is the figure of two instances
sharing no appearance value. Each bracketed part ``[p] P = sqrt(high) P_high + sqrt(low)
P_low`` has a full-dimensional vector (independent draws are nearly orthogonal) and a unit
vector in a small subspace shared by the whole world, which spreads the cosines of two
independent draws (the appearance part's subspace share is the projection of its feature
vector). Groups are ``SemanticConfig.groups`` (a family in no group forms its own). Every
vector but the noise is a function of the world seed and the values, shared by all robots.

``SemanticConfig.view_dependence: false`` sets ``v_s`` to 0 (the descriptor does not change
with the viewing direction but through the light); ``lighting: false`` sets ``l`` to 0; their
energy goes to the appearance part. Only this encoder honours the two switches
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
from roman_sim.frontend.appearance import AppearanceFeatures, AppearanceModel, InstanceLooks, SceneLooks, unknown_looks
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
    appearance: AppearanceModel = Field(default_factory=AppearanceModel)
    view_reference: float = Field(
        0.2, gt=0, le=1, description="front-back asymmetry of a shape that takes the whole configured view fall"
    )
    merged_min_share: float = Field(
        0.1,
        ge=0,
        le=1,
        description=(
            "a mask over several objects (under-segmentation) is described by the pixel-share blend of every object "
            "with at least this share of its object pixels (1: always by the majority object alone)"
        ),
    )
    lighting_fall: float = Field(
        0.64,
        ge=0,
        le=2,
        description=(
            "same-face cosine drop from front-lit to back-lit per unit of light strength (sun share times "
            "cos elevation), measured with the pixel encoder (benchmarks/measure_lighting.py, docs/mapping.md); "
            "the light takes at most the view energy, half the same instance's fall"
        ),
    )

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
        cfg: descriptor dimension, confusion, groups, appearance weights, view and light.
        seed: world-level seed: robots sharing it share every vector but the noise.
        families: object id -> family name (from ``WorldTruth``).
        robot: name keying this robot's independent observation-noise stream.
        looks: how the world draws each object, the shapes' asymmetries and the robot's
            light; an object it does not list is drawn as ``unknown_looks`` (every such
            instance of a family alike) and a shape it does not list takes the whole view fall.
    """

    needs_rgb = False
    reads_truth = True

    def __init__(
        self,
        cfg: SemanticConfig | None = None,
        seed: int = 0,
        families: Mapping[int, str] | None = None,
        robot: str = "",
        looks: SceneLooks | None = None,
    ) -> None:
        self.cfg = cfg or SemanticConfig()
        self.seed = seed
        self.families = dict(families or {})
        self.looks = looks or SceneLooks({}, {}, None)
        self.layout = self.cfg.confusion.layout()
        self._groups = self.cfg.group_map()
        self._rng = child_rng(seed, "semantics", "noise", robot)
        self._features = AppearanceFeatures(self.cfg.appearance, seed, self.cfg.dim)
        self._bases: dict[str, NDArray[np.float64]] = {}
        self._static: dict[tuple[int, str], NDArray[np.float64]] = {}
        self._turning: dict[tuple[str, str, str], NDArray[np.float64]] = {}
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
        """One part's vector for ``key`` (a group or family): full-dimensional plus subspace share."""
        rng = child_rng(self.seed, "semantics", level, key)
        v = np.sqrt(part.high) * self._off_common(rng.standard_normal(self.cfg.dim))
        if part.low > 0:
            z = rng.standard_normal(part.dims)
            v = v + np.sqrt(part.low / (z @ z)) * (z @ self._basis(level, part.dims))
        return v

    def group_of(self, family: str) -> str:
        """Group of ``family`` (``SemanticConfig.group_of``)."""
        return self._groups.get(family, f"_{family}")

    def looks_of(self, oid: int, family: str) -> InstanceLooks:
        """How object ``oid`` is drawn (``unknown_looks`` when the world's looks do not list it)."""
        out = self.looks.instances.get(oid)
        return out if out is not None and out.family == family else unknown_looks(family)

    def energies(self, looks: InstanceLooks) -> tuple[float, float, float]:
        """(appearance, view, light) energy shares of an instance drawn as ``looks``.

        The light takes ``lighting_fall / 2`` times the light's strength out of the view
        energy (half the same instance's fall), at most all of it; the view part takes
        ``min(1, asymmetry / view_reference)`` of what is left; what they leave goes to the
        appearance part.
        """
        lay, cfg = self.layout, self.cfg
        light = 0.0
        if cfg.lighting and self.looks.light is not None:
            light = min(0.5 * cfg.lighting_fall * min(max(self.looks.light.strength, 0.0), 1.0), lay.view)
        view = 0.0
        if cfg.view_dependence:
            asym = self.looks.asymmetry.get(looks.shape)
            view = (lay.view - light) * (1.0 if asym is None else min(1.0, asym / cfg.view_reference))
        return lay.instance.weight + lay.view - light - view, view, light

    def static(self, oid: int, family: str) -> NDArray[np.float64]:
        """The view- and noise-free part of object ``oid``'s embedding (terrain: ``oid`` -1)."""
        key = (oid, family)
        if key not in self._static:
            lay = self.layout
            looks = self.looks_of(oid, family)
            energy = self.energies(looks)[0]
            f = self._features.vector(looks)
            inst = lay.instance
            app = np.sqrt(max(energy - inst.low, 0.0)) * self._off_common(f)
            if inst.low > 0:
                z = self._basis("instance", inst.dims) @ f
                app = app + np.sqrt(inst.low / (z @ z)) * (z @ self._basis("instance", inst.dims))
            self._static[key] = (
                np.sqrt(lay.common) * self._common
                + self._part(lay.group, "group", self.group_of(family))
                + self._part(lay.family, "family", family)
                + app
            )
        return self._static[key]

    def _pair(self, kind: str, looks: InstanceLooks) -> NDArray[np.float64]:
        """(2, dim) unit vectors of a turning term (``view`` or ``light``), keyed by the family and shape."""
        key = (kind, looks.family, looks.shape)
        if key not in self._turning:
            ab = child_rng(self.seed, "semantics", *key).standard_normal((2, self.cfg.dim))
            self._turning[key] = np.stack([self._off_common(ab[0]), self._off_common(ab[1])])
        return self._turning[key]

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
        if context.view_dir is not None:
            d = np.asarray(context.view_dir, dtype=np.float64).reshape(3)
            if not np.all(np.isfinite(d)):
                raise ConfigError("semantics: view_dir must be finite")
            phi = float(np.arctan2(d[1], d[0]))
        parts = self.merged(context)
        if parts is None:
            family = self.family_of(context)
            v = self._clean(oid, family, phi, self.static(oid, family) + self._noise())
        else:  # a mask over several objects: each one's clean part by its pixel share, one noise draw
            v = sum((w * self._clean(i, self.families.get(i, "unknown"), phi) for i, w in parts), self._noise())
        return (v / np.sqrt(v @ v)).astype(np.float32)

    def merged(self, context: EncodeContext) -> list[tuple[int, float]] | None:
        """The objects a merged mask shows, with weights (their pixel shares, summing to 1), or None when the
        mask shows one object: at least ``SemanticConfig.merged_min_share`` of the mask's object pixels each,
        two or more of them, and no ``family`` given (a sequence's object table names one family)."""
        if context.shares is None or context.family is not None:
            return None
        objs = [(i, w) for i, w in context.shares if i >= 0]
        total = sum(w for _, w in objs)
        kept = [(i, w) for i, w in objs if total > 0 and w >= self.cfg.merged_min_share * total]
        if len(kept) < 2:
            return None
        norm = sum(w for _, w in kept)
        return [(i, w / norm) for i, w in kept]

    def _clean(self, oid: int, family: str, phi: float, base: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Object ``oid``'s embedding seen along ``phi`` before normalising: ``base`` (its static part, with the
        observation's noise when given) plus its view and light terms."""
        looks = self.looks_of(oid, family)
        _, view, light = self.energies(looks)
        v = self.static(oid, family) if base is None else base
        if view > 0:
            psi = phi - looks.yaw  # the viewing azimuth in the object's own frame
            a, b = self._pair("view", looks)
            v = v + np.sqrt(view) * (np.cos(psi) * a + np.sin(psi) * b)
        if light > 0 and self.looks.light is not None:
            beta = abs(_wrap(phi - self.looks.light.sun_azimuth))  # 0: against the sun, pi: sun behind the camera
            p, q = self._pair("light", looks)
            v = v + np.sqrt(light) * (np.cos(beta) * p + np.sin(beta) * q)
        return v

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


def _wrap(a: float) -> float:
    """``a`` wrapped into [-pi, pi)."""
    return float((a + np.pi) % (2 * np.pi) - np.pi)
