"""Fixtures for world tests: the tiny preset world, and a CLI runner that keeps exit codes."""

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


@pytest.fixture
def run_cli(capsys: pytest.CaptureFixture[str]) -> Callable[..., tuple[int, str, str]]:
    """Run ``roman-sim ARGS`` through the real entry point; returns (exit code, stdout, stderr)."""
    from roman_sim.cli import app

    def run(*args: str) -> tuple[int, str, str]:
        try:
            app(list(args), prog_name="roman-sim")
            code = 0
        except SystemExit as ex:
            code = int(ex.code or 0)
        out = capsys.readouterr()
        return code, out.out, out.err

    return run
