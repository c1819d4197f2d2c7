"""Object families and the world spec / presets."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.seeding import child_rng
from roman_sim.world import WORLD_PRESETS, WorldSpec, load_world_spec
from roman_sim.world.assets import FAMILIES
from roman_sim.world.catalog import family_assets, n_variants, scale_levels
from roman_sim.world.spec import FamilySpec

REQUIRED = {"conifer", "deciduous", "bush", "boulder", "stump", "log", "house", "car", "lamp_post", "bench", "fence"}


def test_at_least_ten_families_including_required() -> None:
    assert REQUIRED <= set(FAMILIES.names()) and len(FAMILIES.names()) >= 10


@pytest.mark.parametrize("family", FAMILIES.names())
def test_family_meshes_rest_on_ground_and_are_light(family: str) -> None:
    parts = FAMILIES.get(family)(child_rng(0, "test", family))
    assert 1 <= len(parts) <= 3
    for p in parts:
        assert len(p.mesh.faces) <= 600, (family, p.name, len(p.mesh.faces))
        assert len(p.rgba) == 4 and all(0 <= c <= 1 for c in p.rgba)
    zmin = min(p.mesh.vertices[:, 2].min() for p in parts)
    assert zmin == pytest.approx(0.0, abs=1e-6)


def test_family_parameters_vary_with_the_seed() -> None:
    a = FAMILIES.get("house")(child_rng(0, "a"))[0].mesh.extents
    b = FAMILIES.get("house")(child_rng(0, "b"))[0].mesh.extents
    assert not np.allclose(a, b)


def test_size_variation_zero_gives_one_asset() -> None:
    fam = FamilySpec(name="conifer", density=1.0, scale=(0.5, 1.5), variants=4)
    assert n_variants(fam, 0.0) == 1 and list(scale_levels(fam, 0.0)) == [1.0]
    assert n_variants(fam, 1.0) == 4 and np.allclose(scale_levels(fam, 1.0), [0.5, 1.0, 1.5])
    assets = family_assets(0, fam, 0.5)
    assert len(assets) == n_variants(fam, 0.5) * 3
    # the asset truth matches its (scaled) meshes
    for a in assets:
        v = a.combined().vertices
        assert a.radius == pytest.approx(np.hypot(v[:, 0], v[:, 1]).max())


@pytest.mark.parametrize("preset", WORLD_PRESETS.names())
def test_presets_load(preset: str) -> None:
    spec = load_world_spec(preset)
    assert spec.name == preset and spec.families


def test_preset_by_path_and_unknown_name(tmp_path) -> None:
    assert load_world_spec(str(WORLD_PRESETS.get("tiny"))).name == "tiny"
    with pytest.raises(ConfigError, match="valid: forest, offroad, orchard"):
        load_world_spec("jungle")


def test_ambiguity_knob_maps_onto_the_three() -> None:
    spec = load_world_spec("tiny").model_copy(update={"ambiguity": 0.8})
    assert spec.knobs() == pytest.approx((0.2, 0.2, 0.8))


@pytest.mark.parametrize(
    ("patch", "field"),
    [
        ({"families": [{"name": "conifer", "density": -1}]}, "families.0.density"),
        ({"families": [{"name": "tree", "density": 1}]}, "unknown family 'tree'"),
        ({"families": [{"name": "conifer", "density": 1, "scale": [2, 1]}]}, "families.0.scale"),
        ({"families": [{"name": "conifer", "density": 1000}], "max_objects": 100}, "more than max_objects=100"),
        ({"ambiguity": 1.5}, "ambiguity"),
        ({"extent_m": [5, 5]}, "extent_m"),
        ({"terrain": {"colour": 1}}, "terrain.colour: unknown key"),
        ({"families": [{"name": "bush", "density": 1}, {"name": "bush", "density": 2}]}, "repeated: bush"),
        ({"roads": {"width_m": 40}, "extent_m": [60, 60]}, "roads.width_m: 40.0 m must be below half"),
    ],
)
def test_bad_spec_values_name_the_field(patch: dict, field: str) -> None:
    data = {"families": [{"name": "conifer", "density": 10}], **patch}
    with pytest.raises(ConfigError) as err:
        validate_model(WorldSpec, data, "spec")
    assert field in str(err.value) and "\n" not in str(err.value)
