"""World presets: YAML files shipped with the package (``worlds/`` at the repo root links here).

``load_world_spec`` accepts a preset name (``forest``) or a path to a YAML file.
"""

from __future__ import annotations

from pathlib import Path

from roman_sim.core.config import load_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.registry import Registry
from roman_sim.world.spec import WorldSpec

PRESET_DIR = Path(__file__).resolve().parent

WORLD_PRESETS: Registry[Path] = Registry("world preset")
for _path in sorted(PRESET_DIR.glob("*.yaml")):
    WORLD_PRESETS.register(_path.stem, _path)


def load_world_spec(name_or_path: str) -> WorldSpec:
    """A ``WorldSpec`` from a preset name or a YAML path (``ConfigError`` on bad input)."""
    text = str(name_or_path)
    if text in WORLD_PRESETS:
        return load_model(WorldSpec, WORLD_PRESETS.get(text))
    if text.endswith((".yaml", ".yml")) or Path(text).is_file():
        return load_model(WorldSpec, Path(text))
    raise ConfigError(f"unknown world preset {text!r} (valid: {', '.join(WORLD_PRESETS.names())}, or a .yaml path)")
