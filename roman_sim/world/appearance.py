"""How a world looks: per-instance colour variation, surface textures, lighting and shadows.

None of it changes geometry, so depth and the object-id image are the same whatever the
appearance; only the RGB image changes. Colours vary per instance within a range that each
surface kind (or family part) defines in HSV:

* hue ``h' = h + a * hue_deg * d_h`` (degrees, wrapped),
* saturation ``s' = clip(s + a * sat * d_s, 0, 1)``,
* brightness ``v' = clip(v * (1 + a * val * d_v), 0, 1)``,

where ``a`` is ``appearance.instance_variation`` and ``(d_h, d_s, d_v)`` are uniform in
[-1, 1], drawn per part from ``child_rng(seed, "world", "appearance", "instance", object_id)``.

Textures (``textures: true``): ``texture_px`` pixels cover one tile of a surface (its
``tile_m`` metres). With ``texture_scope: instance`` (the default) each surface kind's texture
is an atlas of ``atlas_tiles`` x ``atlas_tiles`` tiles of one periodic realisation, and every
object part looks at its own region of it, from a seeded offset and turned by a seeded
symmetry of the tile grid, so two instances of one shape show different patterns. The
atlases' memory, ``kinds * (texture_px * atlas_tiles)^2 * 3`` bytes, must stay within
``texture_memory_mb``. ``texture_scope: surface`` gives each kind one tile that every
instance shows alike (every instance of a shape then looks the same up to its colour).

The ground (``roman_sim.world.ground``) is one image over the whole world: with textures,
``ground_texel_m`` texels with detail at every scale (its memory counts towards
``texture_memory_mb``); without, or with ``ground_texel_m: null``, the plain 0.2 m image.

Lighting: one directional sun (azimuth counter-clockwise from the world +x axis, i.e. 0 =
east and 90 = north in an east-north-up world; elevation above the horizon), a uniform
ambient term and a diffuse headlight at the camera. Presets name typical skies; angles left
``null`` are drawn from ``child_rng(seed, "world", "appearance", "lighting")``. A robot may
render under its own preset (``roman_sim.world.relight``).
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, ValidationInfo, field_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import WorldError
from roman_sim.core.registry import Registry
from roman_sim.core.seeding import child_rng

Colour = tuple[float, float, float]
RANDOM_ELEVATION_DEG = (15.0, 75.0)
MAX_TEXTURE_MEMORY_MB = 8192.0
MIN_TEXTURE_PX = 32
MAX_TEXTURE_SIDE_PX = 8192  # widest texture OpenGL implementations commonly take (Mesa's llvmpipe: 16384)
TEXTURE_BYTES_PER_PX = 3  # RGB, 8 bits each (MuJoCo's classic renderer uploads no 1-channel data)


class LightingSpec(StrictModel):
    """Sun, ambient and headlight intensities; angles in degrees (``null``: seeded random).

    The lit colour of a surface is its colour times ``ambient + headlight * cos(view angle)
    + sun * colour * cos(sun angle)``, clipped at 1 (OpenGL's fixed pipeline), so the three
    intensities should add up to about 1 for surfaces not to wash out.
    """

    azimuth_deg: float | None = Field(214.0, ge=-360.0, le=360.0, description="towards the sun, ccw from +x")
    elevation_deg: float | None = Field(70.0, ge=1.0, le=90.0, description="sun above the horizon")
    sun: float = Field(0.5, ge=0.0, le=2.0, description="directional (sun) intensity")
    colour: Colour = Field((1.0, 1.0, 0.95), description="sun colour, RGB in [0, 1]")
    ambient: float = Field(0.3, ge=0.0, le=1.5, description="light on every surface alike")
    headlight: float = Field(0.2, ge=0.0, le=1.5, description="diffuse light from the camera")
    sky: Colour = Field((0.55, 0.7, 0.9), description="sky colour at the zenith, RGB in [0, 1]")

    @field_validator("colour", "sky")
    @classmethod
    def _unit_colour(cls, v: Colour) -> Colour:
        if not all(0.0 <= c <= 1.0 for c in v):
            raise ValueError("each channel must be in [0, 1]")
        return v


LIGHTING: Registry[LightingSpec] = Registry("lighting preset")
LIGHTING.register("noon", LightingSpec())
LIGHTING.register(
    "morning",
    LightingSpec(azimuth_deg=340.0, elevation_deg=20.0, sun=0.75, colour=(1.0, 0.88, 0.72), sky=(0.6, 0.7, 0.85)),
)
LIGHTING.register(
    "evening",
    LightingSpec(
        azimuth_deg=200.0, elevation_deg=10.0, sun=0.7, colour=(1.0, 0.7, 0.45), ambient=0.25, sky=(0.45, 0.5, 0.7)
    ),
)
LIGHTING.register(
    "overcast", LightingSpec(sun=0.12, colour=(0.92, 0.95, 1.0), ambient=0.6, headlight=0.25, sky=(0.72, 0.74, 0.77))
)
LIGHTING.register("random", LightingSpec(azimuth_deg=None, elevation_deg=None))


class AppearanceSpec(StrictModel):
    """Textures, per-instance colour variation, lighting and shadows of a world's RGB images."""

    textures: bool = Field(False, description="procedural textures on objects (bark, foliage, rock, ...)")
    texture_scope: Literal["instance", "surface"] = Field(
        "instance", description="instance: every object part its own texture; surface: one per surface kind"
    )
    texture_px: int = Field(64, ge=MIN_TEXTURE_PX, le=1024, description="texture pixels per tile of a surface")
    atlas_tiles: int = Field(32, ge=2, le=256, description="tiles per side of each surface atlas (instance scope)")
    texture_memory_mb: float = Field(
        512.0, gt=0.0, le=MAX_TEXTURE_MEMORY_MB, description="bound on the surface textures' memory"
    )
    ground_texel_m: float | None = Field(
        0.025,
        ge=0.005,
        le=1.0,
        description="ground texel with textures (longest side at most 8192 px); null: the plain 0.2 m ground",
    )
    instance_variation: float = Field(0.5, ge=0.0, le=1.0, description="fraction of each family's colour range")
    lighting: LightingSpec = Field(default_factory=LightingSpec, description="a preset name or a mapping")
    shadows: bool = Field(False, description="the sun casts shadows (a frame costs about 2x)")
    shadow_px: int = Field(4096, ge=256, le=8192, description="shadow map side")

    @field_validator("atlas_tiles")
    @classmethod
    def _atlas_fits(cls, v: int, info: ValidationInfo) -> int:
        px = info.data.get("texture_px")
        if isinstance(px, int) and px * v > MAX_TEXTURE_SIDE_PX:
            most = MAX_TEXTURE_SIDE_PX // px
            raise ValueError(
                f"an atlas of {v} tiles of texture_px={px} is {px * v} px wide, more than the "
                f"{MAX_TEXTURE_SIDE_PX} px an OpenGL texture may be; allowed: atlas_tiles <= {most}"
            )
        return v

    def texture_side_px(self) -> int:
        """Side of each surface kind's texture: an atlas (instance scope) or one tile."""
        return self.texture_px * (self.atlas_tiles if self.texture_scope == "instance" else 1)

    @field_validator("lighting", mode="before")
    @classmethod
    def _lighting_preset(cls, v: Any) -> Any:
        """A preset name, or a mapping of fields (``preset: name`` starts from that preset)."""
        if isinstance(v, str):
            return _preset(v).model_dump()
        if isinstance(v, dict) and "preset" in v:
            rest = {k: x for k, x in v.items() if k != "preset"}
            return {**_preset(str(v["preset"])).model_dump(), **rest}
        return v


def texture_memory_mb(n_textures: int, side_px: int) -> float:
    """Memory (MiB) of ``n_textures`` square RGB textures of side ``side_px``."""
    return n_textures * side_px**2 * TEXTURE_BYTES_PER_PX / 2**20


def ground_shape(extent_m: tuple[float, float], texel_m: float) -> tuple[int, int]:
    """(rows, cols) of a ground image of ``texel_m`` texels over ``extent_m`` (longer side at most
    ``MAX_TEXTURE_SIDE_PX``: coarser texels beyond that)."""
    px = max(texel_m, max(extent_m) / MAX_TEXTURE_SIDE_PX)
    return max(8, int(round(extent_m[1] / px))), max(8, int(round(extent_m[0] / px)))


def ground_memory_mb(spec: AppearanceSpec, extent_m: tuple[float, float]) -> float:
    """Memory (MiB) of the detailed ground image (0 when the world has the plain one)."""
    if not spec.textures or spec.ground_texel_m is None:
        return 0.0
    rows, cols = ground_shape(extent_m, spec.ground_texel_m)
    return rows * cols * TEXTURE_BYTES_PER_PX / 2**20


def check_texture_memory(spec: AppearanceSpec, n_kinds: int, extent_m: tuple[float, float]) -> None:
    """``WorldError`` naming the fields when ``n_kinds`` surface textures and the ground image of a
    world of ``extent_m`` exceed ``spec.texture_memory_mb``."""
    side = spec.texture_side_px()
    atlases = texture_memory_mb(n_kinds, side)
    ground = ground_memory_mb(spec, extent_m)
    need = atlases + ground
    if need <= spec.texture_memory_mb:
        return
    room = max(spec.texture_memory_mb - ground, 0.0)
    tiles = int(np.sqrt(room * 2**20 / (TEXTURE_BYTES_PER_PX * max(n_kinds, 1)))) // spec.texture_px
    what = f"{n_kinds} surface atlases" if spec.texture_scope == "instance" else f"{n_kinds} surface textures"
    atlas = spec.texture_scope == "instance" and tiles >= 2
    fix = f"appearance.atlas_tiles <= {tiles} at this bound, " if atlas else ""
    parts = f"{what} of {side} x {side} px x {TEXTURE_BYTES_PER_PX} B"
    if ground > 0:
        rows, cols = ground_shape(extent_m, spec.ground_texel_m or 0.0)
        parts += f" + a ground image of {cols} x {rows} px ({ground:.3g} MB)"
        ground_room = spec.texture_memory_mb - atlases
        if ground_room > 0:
            texel = np.sqrt(extent_m[0] * extent_m[1] * TEXTURE_BYTES_PER_PX / (ground_room * 2**20))
            fix += f"appearance.ground_texel_m >= {np.ceil(texel * 1e3) / 1e3:g}, "
    raise WorldError(
        f"appearance.texture_memory_mb: {parts} = {need:.3g} MB, "
        f"over the bound of {spec.texture_memory_mb:g} MB; allowed: {fix}a smaller appearance.texture_px, "
        f"appearance.texture_memory_mb >= {need:.3g} (at most {MAX_TEXTURE_MEMORY_MB:g}), or "
        "appearance.texture_scope: surface"
    )


def _preset(name: str) -> LightingSpec:
    if name not in LIGHTING:
        raise ValueError(f"unknown lighting preset {name!r} (valid: {', '.join(LIGHTING.names())}, or a mapping)")
    return LIGHTING.get(name)


@dataclass(frozen=True)
class Sun:
    """The resolved sun of one world: angles in degrees and the unit vector towards it."""

    azimuth_deg: float
    elevation_deg: float

    @property
    def towards(self) -> NDArray[np.float64]:
        """(3,) unit vector from the ground towards the sun (world frame)."""
        az, el = np.radians(self.azimuth_deg), np.radians(self.elevation_deg)
        return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def resolve_sun(lighting: LightingSpec, seed: int, *stream: str | int) -> Sun:
    """The sun angles of ``lighting``, drawing the ``null`` ones from ``child_rng(seed, *stream)``.

    The stream defaults to the world's, ``("world", "appearance", "lighting")``.
    """
    rng = child_rng(seed, *(stream or ("world", "appearance", "lighting")))
    az, el = rng.uniform(0.0, 360.0), rng.uniform(*RANDOM_ELEVATION_DEG)  # drawn always: stable streams
    return Sun(
        azimuth_deg=float(az if lighting.azimuth_deg is None else lighting.azimuth_deg),
        elevation_deg=float(el if lighting.elevation_deg is None else lighting.elevation_deg),
    )


@dataclass(frozen=True)
class Variation:
    """Half-widths of a colour range at ``instance_variation = 1`` (hue in degrees, value relative)."""

    hue_deg: float
    sat: float
    val: float


def vary_rgba(
    rgba: tuple[float, ...], var: Variation, amount: float, draws: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``rgba`` moved within ``var`` scaled by ``amount``; ``draws`` = (d_h, d_s, d_v) in [-1, 1]."""
    h, s, v = colorsys.rgb_to_hsv(*rgba[:3])
    h = (h + amount * var.hue_deg * float(draws[0]) / 360.0) % 1.0
    s = float(np.clip(s + amount * var.sat * float(draws[1]), 0.0, 1.0))
    v = float(np.clip(v * (1.0 + amount * var.val * float(draws[2])), 0.0, 1.0))
    return np.array([*colorsys.hsv_to_rgb(h, s, v), rgba[3]], dtype=np.float64)


def instance_draws(seed: int, obj_id: int, n_parts: int) -> NDArray[np.float64]:
    """(n_parts, 3) uniform draws in [-1, 1] of one object's colour variation."""
    return child_rng(seed, "world", "appearance", "instance", obj_id).uniform(-1.0, 1.0, (n_parts, 3))
