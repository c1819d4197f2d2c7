"""Fixtures for world tests: the tiny preset world and small specs of the presets."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from roman_sim.core.config import validate_model
from roman_sim.world import World, WorldSpec, generate, load_world_spec


@pytest.fixture(scope="session")
def tiny_world() -> World:
    return generate(load_world_spec("tiny"), 0)


def _small_spec(preset: str, side_m: float = 80.0, **updates: object) -> WorldSpec:
    data = load_world_spec(preset).model_dump(mode="json")
    data.update(extent_m=[side_m, side_m], **updates)
    return validate_model(WorldSpec, data, preset)


@pytest.fixture
def small_spec() -> Callable[..., WorldSpec]:
    """``small_spec(preset, side_m=80, **updates)``: a preset shrunk to a square, validated."""
    return _small_spec
