"""A tiny scenario (tiny world, 160 x 120 and 64 x 48 images, two robots of 3 s and 1 s) and its exports."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from roman_sim.core.config import validate_model
from roman_sim.pipeline.scenario import Scenario

TINY = {
    "name": "tiny_export",
    "seed": 0,
    "world": {
        "preset": "tiny",
        "overrides": {"families.0.density": 180, "families.2.density": 120, "families.3.density": 90},
    },
    "robots": [
        {
            "name": "a",
            "path": {"kind": "road", "road_index": 0},
            "camera": {"width": 160, "height": 120},
            "max_duration_s": 3.0,
        },
        {
            "name": "b",
            "path": {"kind": "reverse_of", "of": "a"},
            "camera": {"width": 64, "height": 48},
            "max_duration_s": 1.0,
            "render_rgb": False,
        },
    ],
    "frontend": {"segmenter": "perfect"},
}
FRAMES = {"a": 19, "b": 7}  # 6 Hz for 3 s and 1 s, both ends included
#: The documented epoch of exported stamps, 2023-11-14 22:13:20 UTC, in nanoseconds.
EPOCH_NS = 1_700_000_000_000_000_000


@pytest.fixture(scope="session")
def tiny_scenario() -> Scenario:
    return validate_model(Scenario, TINY, source="tiny_export")


@pytest.fixture(scope="session")
def direct_frames(tiny_scenario: Scenario) -> dict[str, list[Any]]:
    """The frames the exporter renders, straight from the simulator (RGB on)."""
    from roman_sim.interop.source import scenario_streams

    _, streams = scenario_streams(tiny_scenario)
    return {s.name: list(s.frames()) for s in streams}


@pytest.fixture(scope="session")
def tum_export(tiny_scenario: Scenario, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from roman_sim.interop import export_scenario

    out = tmp_path_factory.mktemp("tum") / "export"
    export_scenario(tiny_scenario, "tum", out)
    return out


@pytest.fixture(scope="session")
def bag_export(tiny_scenario: Scenario, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from roman_sim.interop import export_scenario

    out = tmp_path_factory.mktemp("bag") / "export"
    export_scenario(tiny_scenario, "rosbag2", out)
    return out
