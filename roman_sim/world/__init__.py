"""Procedural outdoor worlds: spec, presets, generation, export and ground truth."""

from roman_sim.world.build import HasTruth, PickledWorld, TruthOnlyWorld, World, generate, generate_truth
from roman_sim.world.export import export_world, load_world
from roman_sim.world.presets import WORLD_PRESETS, load_world_spec
from roman_sim.world.spec import WorldSpec

__all__ = [
    "WORLD_PRESETS",
    "HasTruth",
    "PickledWorld",
    "TruthOnlyWorld",
    "World",
    "WorldSpec",
    "export_world",
    "generate",
    "generate_truth",
    "load_world",
    "load_world_spec",
]
