"""What the simulated encoder knows of how an instance looks, and the feature maps of those values.

An instance's appearance is the VALUES the renderer draws it with (``InstanceLooks``): its
family and shape variant, its scale, each part's base colour (CIELAB) and, with per-instance
textures, each part's region of its surface atlas (tile-grid symmetry and offset). The
encoder's instance part is a weighted sum of one feature map per attribute,

    a(x) = sum_p sqrt(w_p / W) phi_p(x_p),    W = sum_p w_p,

each ``phi_p`` seeded per world, attribute and family (never per object), so that the
expected inner product of two values is a stated kernel of their difference:

* shape variant: 1 if equal, else 0 (a Gaussian vector per value);
* scale: ``exp(-(ln s1 - ln s2)^2 / (2 l_s^2))`` between instances of one shape variant, 0
  between shapes (random Fourier features of ln s, seeded per shape);
* colour: per part, weighted by its share of the surface, ``exp(-dE^2 / (2 l_c^2))`` of the
  CIELAB distance dE (random Fourier features of L*a*b*);
* texture region: per part, 0 for different tile-grid symmetries, else a periodic Gaussian of
  the offset difference on the atlas torus with length ``l_t`` tiles (random Fourier features
  at integer frequencies); an untextured part (or one surface texture for all) is one value.

Two instances drawn with the same values therefore get the same vector exactly; two drawn
apart get ``sum_p w_p k_p / W`` (up to the random features' sampling error, about
1/sqrt(dim)). ``AppearanceModel`` holds the weights and lengths; their sources are in its
docstring and in ``docs/mapping.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.seeding import child_rng

#: Attributes of an instance's appearance, in the order of ``AppearanceModel``'s weights.
ATTRIBUTES = ("shape", "scale", "colour", "texture")


@dataclass(frozen=True)
class PartLooks:
    """One part of an instance as rendered.

    Attributes:
        name: the part's name in its family (``crown``, ``trunk``, ...): keys its feature maps.
        lab: its base colour (the geom's RGB before texture and light) in CIELAB.
        area: its share of the instance's surface (the parts' shares add up to 1).
        texture: (symmetry index, u, v): its region of the surface atlas, offset in tiles, with
            per-instance textures; None when every instance of its shape shows one texture.
    """

    name: str
    lab: tuple[float, float, float]
    area: float
    texture: tuple[int, float, float] | None = None


@dataclass(frozen=True)
class InstanceLooks:
    """How one instance is drawn: family, shape variant, scale, heading and parts.

    Attributes:
        family: its family.
        shape: its shape variant (``conifer_v1``): every instance of one shape has one mesh up to scale.
        scale: its scale factor.
        yaw: its heading in the world (rad): the object frame's +x from the world's +x, counter-clockwise.
        parts: its parts as rendered.
        atlas_tiles: tiles per side of the surface atlases (the texture offsets' period).
    """

    family: str
    shape: str
    scale: float
    yaw: float
    parts: tuple[PartLooks, ...]
    atlas_tiles: int = 1


@dataclass(frozen=True)
class SceneLight:
    """The light a robot renders under, as the encoder's lighting term reads it.

    Attributes:
        sun_azimuth: the sun's azimuth (rad, counter-clockwise from the world's +x).
        sun_elevation: the sun's elevation above the horizon (rad).
        sun_share: the sun's intensity over the sum of sun, ambient and headlight.
    """

    sun_azimuth: float
    sun_elevation: float
    sun_share: float

    @property
    def strength(self) -> float:
        """How strongly the view's side of the sun shows: ``sun_share * cos(elevation)`` (0 at noon overhead)."""
        return float(self.sun_share * math.cos(self.sun_elevation))


class AppearanceModel(StrictModel):
    """Weights and kernel lengths of the appearance attributes (``frontend.semantics.appearance``).

    Each weight is the share of the instance part that a full difference in that attribute
    moves; the lengths say how large a difference is full. Source of the weights: measured
    with the project's pixel encoder (``frontend.image_encoder``) on rasterised crops of the
    built-in shapes differing in one attribute (``benchmarks/measure_appearance.py``: 1 -
    cosine 0.070 for another shape variant, 0.048 for the smallest against the largest scale,
    0.160 for the two ends of a colour range, 0.015 for another region of one texture),
    normalised over the four and rounded. A histogram encoder is nearly blind to silhouettes,
    so the shape weight is a lower bound for a CLIP-like encoder, whose shape bias grows over
    training (Hernandez-Camara et al., arXiv 2508.09814). ``colour_length``: a CIELAB dE of
    about 2 is just noticeable and colour names lie tens of units apart (Sharma et al., "The
    CIEDE2000 color-difference formula", 2005), so two colours 20 dE apart keep exp(-1/2).
    ``texture_length``: a quarter tile, the scale of a texture's smallest features.
    """

    shape: float = Field(0.24, ge=0, le=1, description="weight of the shape variant")
    scale: float = Field(0.16, ge=0, le=1, description="weight of the scale")
    colour: float = Field(0.55, ge=0, le=1, description="weight of the parts' colours")
    texture: float = Field(0.05, ge=0, le=1, description="weight of the parts' texture regions")
    scale_length: float = Field(0.15, gt=0, le=10, description="kernel length of ln(scale)")
    colour_length: float = Field(20.0, gt=0, le=200, description="kernel length of CIELAB dE")
    texture_length: float = Field(0.25, gt=0, le=100, description="kernel length of a texture offset (tiles)")

    @model_validator(mode="after")
    def _some_weight(self) -> AppearanceModel:
        if sum(self.weights()) <= 0:
            raise ValueError(
                "shape, scale, colour and texture are all 0: at least one weight must be positive (each in [0, 1])"
            )
        return self

    def weights(self) -> tuple[float, float, float, float]:
        """The four weights in ``ATTRIBUTES`` order."""
        return (self.shape, self.scale, self.colour, self.texture)

    def kernel(self, a: InstanceLooks, b: InstanceLooks) -> float:
        """The expected inner product of the feature vectors of ``a`` and ``b`` (the model's kernel)."""
        if a.family != b.family:
            return 0.0
        same = float(a.shape == b.shape)
        k = [same, same * math.exp(-(math.log(a.scale / b.scale) ** 2) / (2 * self.scale_length**2))]
        k += [_parts_kernel(a, b, self._colour_kernel), _parts_kernel(a, b, self._texture_kernel)]
        w = self.weights()
        return float(sum(wi * ki for wi, ki in zip(w, k)) / sum(w))

    def _colour_kernel(self, p: PartLooks, q: PartLooks, period: int) -> float:
        d2 = sum((x - y) ** 2 for x, y in zip(p.lab, q.lab))
        return math.exp(-d2 / (2 * self.colour_length**2))

    def _texture_kernel(self, p: PartLooks, q: PartLooks, period: int) -> float:
        if p.texture is None or q.texture is None:
            return float(p.texture is None and q.texture is None)
        if p.texture[0] != q.texture[0]:
            return 0.0
        out = 1.0
        for x, y in zip(p.texture[1:], q.texture[1:]):
            d = (x - y + period / 2) % period - period / 2
            out *= math.exp(-(d * d) / (2 * self.texture_length**2))
        return out


def _parts_kernel(a: InstanceLooks, b: InstanceLooks, k: object) -> float:
    """Area-weighted kernel over the parts two instances share by name (0 for parts only one has)."""
    theirs = {p.name: p for p in b.parts}
    out = 0.0
    for p in a.parts:
        q = theirs.get(p.name)
        if q is not None:
            out += math.sqrt(p.area * q.area) * k(p, q, a.atlas_tiles)  # type: ignore[operator]
    return out


class AppearanceFeatures:
    """The feature maps of one world (``seed``) in ``dim`` dimensions: ``vector(looks)`` is unit.

    Every random direction is keyed by the world seed, the attribute, the family and (for a
    part) the part's name, or by a categorical VALUE (a shape variant, a texture symmetry):
    never by an object. Vectors are cached per instance value.
    """

    def __init__(self, model: AppearanceModel, seed: int, dim: int) -> None:
        self.model = model
        self.seed = seed
        self.dim = dim
        self._rff: dict[tuple[str | int, ...], tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
        self._cache: dict[InstanceLooks, NDArray[np.float64]] = {}

    def _gauss(self, *key: str | int) -> NDArray[np.float64]:
        v = child_rng(self.seed, "semantics", "appearance", *key).standard_normal(self.dim)
        return v / np.linalg.norm(v)

    def _fourier(self, x: Sequence[float], length: float, *key: str | int) -> NDArray[np.float64]:
        """Unit random Fourier features of ``x``: inner products approximate exp(-|x - y|^2 / (2 length^2))."""
        k = (*key, len(x))
        if k not in self._rff:
            rng = child_rng(self.seed, "semantics", "appearance", *key)
            self._rff[k] = (rng.standard_normal((self.dim, len(x))), rng.uniform(0.0, 2 * np.pi, self.dim))
        w, b = self._rff[k]
        v = np.cos(w @ (np.asarray(x, dtype=np.float64) / length) + b)
        return v / np.linalg.norm(v)

    def _periodic(self, x: Sequence[float], length: float, period: int, *key: str | int) -> NDArray[np.float64]:
        """Unit random Fourier features on the torus of ``period``: integer frequencies drawn from
        the Gaussian's spectrum, so inner products approximate the periodic Gaussian of ``length``."""
        k = (*key, "torus", period)
        if k not in self._rff:
            rng = child_rng(self.seed, "semantics", "appearance", *key, "torus", period)
            freq = np.round(rng.standard_normal((self.dim, 2)) * period / (2 * np.pi * length))
            self._rff[k] = (freq * 2 * np.pi / period, rng.uniform(0.0, 2 * np.pi, self.dim))
        w, b = self._rff[k]
        v = np.cos(w @ np.asarray(x, dtype=np.float64) + b)
        return v / np.linalg.norm(v)

    def vector(self, looks: InstanceLooks) -> NDArray[np.float64]:
        """The unit feature vector of ``looks`` (cached)."""
        if looks not in self._cache:
            self._cache[looks] = self._build(looks)
        return self._cache[looks]

    def _build(self, looks: InstanceLooks) -> NDArray[np.float64]:
        m, fam = self.model, looks.family
        w_shape, w_scale, w_colour, w_texture = (w / sum(m.weights()) for w in m.weights())
        out = math.sqrt(w_shape) * self._gauss("shape", fam, looks.shape)
        out = out + math.sqrt(w_scale) * self._fourier(
            [math.log(looks.scale)], m.scale_length, "scale", fam, looks.shape
        )
        for p in looks.parts:
            colour = self._fourier(p.lab, m.colour_length, "colour", fam, p.name)
            if p.texture is None:
                texture = self._gauss("texture", fam, p.name, "one")
            else:
                sym, u, v = p.texture
                texture = self._periodic((u, v), m.texture_length, looks.atlas_tiles, "texture", fam, p.name, sym)
            out = out + math.sqrt(p.area) * (math.sqrt(w_colour) * colour + math.sqrt(w_texture) * texture)
        return out / np.linalg.norm(out)


def srgb_to_lab(rgb: Sequence[float]) -> tuple[float, float, float]:
    """CIELAB (D65) of an sRGB colour with channels in [0, 1]."""
    c = np.clip(np.asarray(rgb, dtype=np.float64)[:3], 0.0, 1.0)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    m = np.array(
        [[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750], [0.0193339, 0.1191920, 0.9503041]]
    )
    xyz = m @ lin / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return (float(116 * f[1] - 16), float(500 * (f[0] - f[1])), float(200 * (f[1] - f[2])))


@dataclass(frozen=True)
class SceneLooks:
    """What the simulated encoder of one robot knows of how its world is drawn.

    Attributes:
        instances: object id -> its ``InstanceLooks``.
        asymmetry: shape -> its front-back asymmetry (``roman_sim.frontend.view_asymmetry``).
        light: the light the robot renders under (None: no lighting term).
    """

    instances: Mapping[int, InstanceLooks]
    asymmetry: Mapping[str, float]
    light: SceneLight | None = None


def reference_looks(family: str, k: int) -> InstanceLooks:
    """An instance of ``family`` that shares no appearance value with ``reference_looks(family, j)``
    for any other ``j`` (its own shape, no parts): the kernel-0 instances the configured
    ``same_family`` relation describes (``roman_sim.frontend.semantics_stats``)."""
    return InstanceLooks(family, f"reference_{k}", 1.0, 0.0, ())


def unknown_looks(family: str) -> InstanceLooks:
    """The looks of an object whose appearance nobody recorded (a sequence's object table): every
    such instance of a family is drawn alike, since nothing tells them apart."""
    return InstanceLooks(family, "unknown", 1.0, 0.0, ())


#: A part as the looks record holds it: name, CIELAB colour, surface share, texture region (or None).
PartRow = tuple[str, tuple[float, float, float], float, tuple[int, float, float] | None]


@dataclass(frozen=True)
class InstanceRow:
    """An ``InstanceLooks`` as the looks record holds it (parts as rows)."""

    family: str
    shape: str
    scale: float
    yaw: float
    atlas_tiles: int
    parts: list[PartRow]


@dataclass(frozen=True)
class LooksRecord:
    """``SceneLooks`` as JSON (an object table's ``looks``): instances by id, asymmetry by shape, the
    light as (sun azimuth, elevation, share); read back exactly."""

    instances: dict[str, InstanceRow]
    asymmetry: dict[str, float]
    light: tuple[float, float, float] | None

    @classmethod
    def of(cls, looks: SceneLooks) -> LooksRecord:
        """The record of ``looks``."""
        light = looks.light
        instances = {
            str(oid): InstanceRow(
                i.family,
                i.shape,
                i.scale,
                i.yaw,
                i.atlas_tiles,
                [(p.name, p.lab, p.area, p.texture) for p in i.parts],
            )
            for oid, i in sorted(looks.instances.items())
        }
        sun = None if light is None else (light.sun_azimuth, light.sun_elevation, light.sun_share)
        return cls(instances, dict(sorted(looks.asymmetry.items())), sun)

    def looks(self) -> SceneLooks:
        """Inverse of ``of``."""

        def part(p: PartRow) -> PartLooks:
            tex = None if p[3] is None else (int(p[3][0]), float(p[3][1]), float(p[3][2]))
            return PartLooks(p[0], (float(p[1][0]), float(p[1][1]), float(p[1][2])), float(p[2]), tex)

        instances = {
            int(k): InstanceLooks(
                v.family, v.shape, float(v.scale), float(v.yaw), tuple(part(p) for p in v.parts), v.atlas_tiles
            )
            for k, v in self.instances.items()
        }
        light = None if self.light is None else SceneLight(*(float(x) for x in self.light))
        return SceneLooks(instances, {k: float(v) for k, v in self.asymmetry.items()}, light)
