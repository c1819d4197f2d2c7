"""World specification: extent, terrain, object families, layout, roads, ambiguity knobs and
appearance (textures, per-instance colours, lighting, shadows: ``roman_sim.world.appearance``).

The three ambiguity knobs act on generation as follows (all in [0, 1]):

* ``class_diversity``: 1 keeps every family's density as given; lower values move that
  fraction of all objects into the densest family (0 = a single family).
* ``size_variation``: 1 keeps each family's ``scale`` range and ``variants`` shape
  variants; 0 collapses the range to its middle and uses one shape variant.
* ``layout_regularity``: 0 places objects with full random jitter and random yaw; 1 puts
  them exactly on the layout's lattice (grid / rows / road offsets) with a common yaw.

The optional ``ambiguity`` knob ``a`` overrides all three:
``class_diversity = 1 - a``, ``size_variation = 1 - a``, ``layout_regularity = a``.
"""

from __future__ import annotations

from enum import Enum

from pydantic import Field, field_validator, model_validator
from pydantic_core import PydanticCustomError

from roman_sim.core.config import StrictModel
from roman_sim.world.appearance import AppearanceSpec


class LayoutKind(str, Enum):
    """How a family's objects are placed."""

    uniform = "uniform"
    clustered = "clustered"
    rows = "rows"
    roadside = "roadside"


class RoadStyle(str, Enum):
    """Road network styles (see ``roman_sim.world.roads``)."""

    loop = "loop"
    cross = "cross"
    loop_cross = "loop_cross"
    grid = "grid"


class TerrainSpec(StrictModel):
    """Fractal-noise heightfield."""

    amplitude_m: float = Field(1.0, ge=0.0, le=50.0, description="peak-to-mean height scale")
    roughness: float = Field(0.5, ge=0.0, le=1.0, description="octave persistence")
    feature_size_m: float = Field(40.0, gt=1.0, le=1000.0, description="largest noise wavelength")
    octaves: int = Field(4, ge=1, le=8)
    resolution_m: float = Field(1.0, ge=0.1, le=10.0, description="hfield cell size")


class FamilySpec(StrictModel):
    """One object family in a world."""

    name: str = Field(description="family name (see `roman-sim list families`)")
    density: float = Field(ge=0.0, le=2000.0, description="objects per hectare")
    scale: tuple[float, float] = Field((0.8, 1.2), description="uniform scale range (min, max)")
    variants: int = Field(3, ge=1, le=8, description="shape variants at full size_variation")
    layout: LayoutKind | None = Field(None, description="override of the world layout kind")

    @field_validator("name")
    @classmethod
    def _known_family(cls, v: str) -> str:
        from roman_sim.world.assets import FAMILIES

        if v not in FAMILIES:
            raise ValueError(f"unknown family {v!r} (valid: {', '.join(FAMILIES.names())})")
        return v

    @field_validator("scale")
    @classmethod
    def _scale_range(cls, v: tuple[float, float]) -> tuple[float, float]:
        if not (0.1 <= v[0] <= v[1] <= 10.0):
            raise ValueError("must be (min, max) with 0.1 <= min <= max <= 10")
        return v


class LayoutSpec(StrictModel):
    """Default placement of the world's families."""

    kind: LayoutKind = LayoutKind.uniform
    row_spacing_m: float = Field(6.0, ge=1.0, le=100.0, description="rows layout: row pitch")
    cluster_count: int = Field(8, ge=1, le=500, description="clustered layout: patch count")
    cluster_radius_m: float = Field(12.0, ge=1.0, le=500.0)
    min_gap_m: float = Field(0.3, ge=0.0, le=20.0, description="gap between footprints")
    roadside_offset_m: float = Field(3.0, ge=0.0, le=50.0, description="beyond the road edge")


class RoadSpec(StrictModel):
    """Road network kept free of objects."""

    style: RoadStyle = RoadStyle.loop_cross
    width_m: float = Field(6.0, ge=0.0, le=50.0, description="object-free corridor width")
    margin_frac: float = Field(0.2, ge=0.02, le=0.45, description="loop inset from the edge")
    spacing_m: float = Field(50.0, ge=10.0, le=1000.0, description="grid style: road pitch")


class WorldSpec(StrictModel):
    """A procedural world: extent, terrain, families, layout, roads and ambiguity knobs."""

    name: str = "world"
    extent_m: tuple[float, float] = Field((200.0, 200.0), description="(x, y) size in metres")
    terrain: TerrainSpec = TerrainSpec()
    families: list[FamilySpec] = Field(min_length=1)
    layout: LayoutSpec = LayoutSpec()
    roads: RoadSpec = RoadSpec()
    class_diversity: float = Field(1.0, ge=0.0, le=1.0)
    size_variation: float = Field(1.0, ge=0.0, le=1.0)
    layout_regularity: float = Field(0.0, ge=0.0, le=1.0)
    ambiguity: float | None = Field(None, ge=0.0, le=1.0, description="overrides the 3 knobs")
    max_objects: int = Field(5000, ge=1, le=20000)
    appearance: AppearanceSpec = Field(default_factory=AppearanceSpec, description="textures, colours, lighting")

    @field_validator("extent_m")
    @classmethod
    def _extent(cls, v: tuple[float, float]) -> tuple[float, float]:
        if not (10.0 <= v[0] <= 2000.0 and 10.0 <= v[1] <= 2000.0):
            raise ValueError("each side must be in [10, 2000] m")
        return v

    @field_validator("families")
    @classmethod
    def _unique_families(cls, v: list[FamilySpec]) -> list[FamilySpec]:
        names = [f.name for f in v]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"each family may appear once; repeated: {', '.join(dup)}")
        return v

    @model_validator(mode="after")
    def _fits(self) -> WorldSpec:
        area_ha = self.extent_m[0] * self.extent_m[1] / 1e4
        expected = sum(f.density for f in self.families) * area_ha
        if expected > self.max_objects:
            raise PydanticCustomError(
                "too_many_objects",
                "families: densities ask for {n} objects, more than max_objects={m}; "
                "lower a density or the extent, or raise max_objects (<= 20000)",
                {"n": round(expected), "m": self.max_objects},
            )
        if self.roads.width_m >= 0.5 * min(self.extent_m):
            raise PydanticCustomError(
                "road_too_wide",
                "roads.width_m: {w} m must be below half the smaller extent side",
                {"w": self.roads.width_m},
            )
        return self

    def knobs(self) -> tuple[float, float, float]:
        """Effective (class_diversity, size_variation, layout_regularity)."""
        if self.ambiguity is not None:
            a = self.ambiguity
            return 1.0 - a, 1.0 - a, a
        return self.class_diversity, self.size_variation, self.layout_regularity

    def family_layout(self, fam: FamilySpec) -> LayoutKind:
        """The layout kind used for ``fam``."""
        return fam.layout or self.layout.kind
