"""The ground-truth ambiguity index: hand-built layouts, preset ordering, the knob."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import WorldError
from roman_sim.core.geometry import make_T
from roman_sim.world import generate
from roman_sim.world.ambiguity import ambiguity_index, place_ambiguity
from roman_sim.world.truth import ObjectTruth, Terrain, WorldTruth


def _truth(xy: np.ndarray, families: list[str], sizes: np.ndarray) -> WorldTruth:
    objs = []
    for i, ((x, y), f, s) in enumerate(zip(xy, families, sizes)):
        ext = np.array([s, s / 2, s / 3])
        objs.append(
            ObjectTruth(i, f, make_T(None, [x, y, 0]), ext, 1.0, np.array([x, y, 0]), [], [], np.eye(4), ext, 1.0)
        )
    return WorldTruth(objs, Terrain(200.0, 200.0, np.zeros((3, 3))))


def test_identical_lattice_is_fully_ambiguous() -> None:
    g = np.arange(-40.0, 41.0, 5.0)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    truth = _truth(xy, ["deciduous"] * len(xy), np.full(len(xy), 4.0))
    assert place_ambiguity(truth, [0.0, 0.0]) == pytest.approx(1.0)


def test_distinct_families_or_sizes_remove_the_ambiguity() -> None:
    g = np.arange(-40.0, 41.0, 5.0)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    rng = np.random.default_rng(0)
    sizes = 2.0 * 1.5 ** np.arange(len(xy))  # every object a distinct size
    assert place_ambiguity(_truth(xy, ["a"] * len(xy), sizes), [0.0, 0.0]) == 0.0
    random_xy = rng.uniform(-40, 40, (250, 2))
    fams = [f"f{k}" for k in rng.integers(0, 6, 250)]
    assert place_ambiguity(_truth(random_xy, fams, np.full(250, 3.0)), [0.0, 0.0]) < 0.25


def test_too_few_objects_and_bad_arguments() -> None:
    truth = _truth(np.array([[0.0, 0.0], [3.0, 0.0]]), ["a", "a"], np.ones(2))
    assert place_ambiguity(truth, [0.0, 0.0]) == 0.0
    with pytest.raises(WorldError):
        place_ambiguity(truth, [0.0, 0.0], radius_m=-1.0)
    with pytest.raises(WorldError):
        ambiguity_index(truth, n_places=0)


def test_presets_order_orchard_forest_park(small_spec) -> None:
    values = {
        p: ambiguity_index(generate(small_spec(p, 100.0), 0).truth, n_places=30) for p in ("orchard", "forest", "park")
    }
    assert values["orchard"] > values["forest"] > values["park"]
    assert values["orchard"] > 0.5


def test_index_rises_with_the_ambiguity_knob(small_spec) -> None:
    values = [
        ambiguity_index(generate(small_spec("forest", 70.0, ambiguity=a), 0).truth, n_places=25)
        for a in (0.0, 0.5, 1.0)
    ]
    assert values[0] < values[1] < values[2]
