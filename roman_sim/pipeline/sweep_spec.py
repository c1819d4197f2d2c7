"""What a sweep is: its configuration (base scenario, grid, seeds, executor) and its runs."""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass
from typing import Any

from pydantic import Field

from roman_sim.core.config import FiniteTree, StrictModel
from roman_sim.core.errors import ConfigError
from roman_sim.runner.executor_base import ExecutorConfig


class SweepConfig(StrictModel):
    """A sweep: base scenario, grid of overrides, seeds, executor."""

    name: str = Field(..., min_length=1)
    description: str = ""
    scenario: str = Field(..., description="scenario name or YAML path (relative to the sweep file)")
    grid: dict[str, list[FiniteTree]] = Field(default_factory=dict)
    seeds: list[int] = Field(default_factory=lambda: [0], min_length=1)
    executor: ExecutorConfig = ExecutorConfig()


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep."""

    run_id: str
    overrides: tuple[str, ...]
    seed: int
    params: dict[str, Any]


def expand(cfg: SweepConfig) -> list[RunSpec]:
    """Every grid combination x seed, in a stable order."""
    keys = sorted(cfg.grid)
    for k in keys:
        if not cfg.grid[k]:
            raise ConfigError(f"grid.{k}: needs at least one value")
    runs = []
    for values in itertools.product(*(cfg.grid[k] for k in keys)):
        params = dict(zip(keys, values))
        ovr = tuple(f"{k}={json.dumps(v)}" for k, v in params.items())
        tag = hashlib.sha1(json.dumps(params, sort_keys=True).encode()).hexdigest()[:8] if params else "base"
        for seed in cfg.seeds:
            runs.append(RunSpec(run_id=f"{tag}-s{seed}", overrides=ovr, seed=seed, params=params))
    return runs
