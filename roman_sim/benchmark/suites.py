"""Benchmark suites: which crossing scenes, ambiguity levels, seeds and methods a benchmark runs.

A suite is a crossing scene template (``scenes.CrossingScene``), a set of named
ambiguity levels (values of the world's ambiguity knob), and its seeds: either a fixed
list, or seeds 0, 1, 2, ... added per level until the level holds ``min_worlds`` worlds
(one count for every level, or a count per level) and (with ``min_relevant_per_bin``) the
*planned* relevant cross-robot pairs (from the trajectories, before anything is rendered)
reach that number in every heading bin, at most ``max_seeds``. One (level, seed) is one
cell (one world): one run folder.

Built-in suites (``SUITES``):

- ``quick``: a first look and CI: one small scene per level, no colour images, three
  methods (a few minutes on 2 cores).
- ``standard``: every paper method on small worlds (8 robots, 40 m drives, colour images of
  320 x 240) at five levels placed by measured ambiguity index (``STANDARD_INDEX``: about
  0.05, 0.15, 0.30, 0.45 and 0.85), with the worlds a paired difference of held-out recall
  of 0.10 needs for power 0.8 (``STANDARD_WORLDS``, from a pilot board), 60 deg heading bins;
  the leaderboard also checks every level x bin's 95 % world-bootstrap interval of held-out
  recall against +-0.1. ``min_relevant_per_bin`` (100) keeps the pooled Wilson intervals of
  the per-bin operating points within +-0.1 too; with these world counts it adds no seed.
- ``envelope``: the standard levels with 4 worlds each, once per front end (``FRONTENDS``).

Levels of ``quick``: ``low`` (knob 0: measured ambiguity index about 0.05, like the park and
forest presets), ``medium`` (0.9: about 0.45) and ``high`` (0.95: about 0.86, like the
orchard preset); the leaderboard reports the index measured on each level's pairs.
A suite may also be a YAML file with the fields of ``BenchmarkSuite``.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import Field, model_validator

from roman_sim.benchmark.scenes import CrossingScene
from roman_sim.core.config import StrictModel, read_yaml, validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.registry import Registry, import_object
from roman_sim.evaluation.paired_worlds import EFFECT, POWER
from roman_sim.pipeline.scenario import method_label

#: The paper's methods (every built-in method the standard suite scores).
PAPER_METHODS = ["roman", "clipper", "clipper_prune", "ransac100k", "ransac1m", "visual"]
#: Ambiguity levels of the built-in suites: name -> the world's ambiguity knob.
LEVELS = {"low": 0.0, "medium": 0.9, "high": 0.95}
#: The measured ambiguity index each standard level is placed at.
STANDARD_INDEX = {"low": 0.05, "mild": 0.15, "moderate": 0.30, "medium": 0.45, "high": 0.85}
#: The standard suite's levels: the knob values that put the measured ambiguity index of a level's pairs
#: there (``benchmarks/measure_levels.py``, 8 worlds a knob; low is the knob's least, index 0.04).
STANDARD_LEVELS = {"low": 0.0, "mild": 0.758, "moderate": 0.866, "medium": 0.9, "high": 0.952}
#: Worlds per standard level: a paired difference of 0.10 detected with power 0.8, at least 8 a level, from
#: the pilot below (``power_plan.planned_worlds``: its worlds for 0.05 interpolated in the index to each
#: level and divided by four; ``benchmarks/out/standard_pilot.json`` is its leaderboard).
STANDARD_WORLDS = {"low": 22, "mild": 20, "moderate": 16, "medium": 12, "high": 8}
STANDARD_PILOT = (
    "the previous standard board (30 / 8 / 8 worlds at index 0.04 / 0.45 / 0.84, 160 x 120), which for 0.05"
    " needs 88 / 47 / 11 worlds (roman - visual 60-120 deg, clipper - visual 0-60 deg, clipper - visual 0-60 deg)"
)


#: Front ends a suite may run with (``frontends``): name -> the scene overrides that select it. ``simulated``
#: is the scenario default (the simulated FastSAM-like segmenter and the simulated encoder); ``paper`` its
#: preset calibrated to the cited CLIP statistics; ``image`` the front end that sees only pixels (the image
#: segmenter and encoder).
FRONTENDS: dict[str, list[str]] = {
    "simulated": [],
    "paper": ["frontend.preset=paper"],
    "image": ["frontend.segmenter=image", "frontend.encoder=image"],
}


class PowerPlan(StrictModel):
    """The worlds each level needs for its paired verdicts' power (``roman_sim.benchmark.power_plan``).

    ``worlds``: per level, the worlds a paired difference of held-out recall of ``effect`` (0.05
    unless stated: ``paired_worlds.EFFECT``) needs to be detected with power 0.8
    (``paired_worlds.POWER``), as a pilot board measured them (``power_plan.pilot_plan``; the
    worlds for another effect scale as one over its square); ``pilot``: what the figures come
    from (the pilot's folder or commit, and what it needed for 0.05 when the suite plans a larger
    effect). A level planned with fewer worlds than this is refused.
    """

    worlds: dict[str, int] = Field(..., min_length=1)
    effect: float = Field(EFFECT, gt=0.0, le=1.0, description="the paired difference of recall planned for")
    pilot: str = Field(..., min_length=1, description="the pilot board the worlds come from")

    @model_validator(mode="after")
    def _check(self) -> "PowerPlan":
        for level, n in self.worlds.items():
            if n < 2:
                raise ValueError(f"worlds.{level}: a paired test needs at least 2 worlds, got {n}")
        return self


class BenchmarkSuite(StrictModel):
    """A benchmark suite (see the module docstring)."""

    name: str = Field(..., min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    scene: CrossingScene = Field(default_factory=CrossingScene)
    levels: dict[str, float] = Field(default_factory=lambda: dict(LEVELS), min_length=1)
    seeds: list[int] = Field(
        default_factory=lambda: [0], description="fixed seeds (without min_relevant_per_bin and min_worlds)"
    )
    min_relevant_per_bin: int | None = Field(
        None, ge=1, description="add seeds per level until every heading bin plans this many relevant pairs"
    )
    min_worlds: int | dict[str, int] | None = Field(
        None, description="add seeds per level until it has this many worlds (one count, or one per level)"
    )
    max_seeds: int = Field(12, ge=1, le=1000, description="most seeds per level when adding them")
    heading_bin_deg: float = Field(30.0, gt=0.0, le=180.0)
    methods: list[str] = Field(default_factory=lambda: list(PAPER_METHODS), min_length=1)
    power: PowerPlan | None = Field(None, description="the worlds per level a pilot says the verdicts need")
    frontends: list[str] | None = Field(
        None, description="run the suite once per front end (names of FRONTENDS) and compare their verdicts"
    )

    @model_validator(mode="after")
    def _check(self) -> "BenchmarkSuite":
        for level, a in self.levels.items():
            if not level or not level.replace("_", "").isalnum():
                raise ValueError(f"levels: level names are letters, digits and _, got {level!r}")
            if not 0.0 <= a <= 1.0:
                raise ValueError(f"levels.{level}: the ambiguity knob lies in [0, 1], got {a}")
        if len(set(self.seeds)) != len(self.seeds) or any(s < 0 for s in self.seeds):
            raise ValueError("seeds: distinct non-negative integers")
        self._check_worlds()
        self._check_frontends()
        if abs(180.0 / self.heading_bin_deg - round(180.0 / self.heading_bin_deg)) > 1e-9:
            raise ValueError(f"heading_bin_deg: must divide 180, got {self.heading_bin_deg:g}")
        return self

    def _check_worlds(self) -> None:
        per = self.min_worlds if isinstance(self.min_worlds, dict) else {}
        unknown = sorted(set(per) - set(self.levels))
        if unknown:
            raise ValueError(f"min_worlds: unknown level {unknown[0]!r} (levels: {', '.join(self.levels)})")
        for level in self.levels:
            n = self.worlds_needed(level)
            where = f"min_worlds.{level}" if level in per else "min_worlds"
            if not 1 <= n <= self.max_seeds:
                raise ValueError(f"{where}: a count from 1 to max_seeds ({self.max_seeds}), got {n}")
        self._check_power()

    def _check_frontends(self) -> None:
        if self.frontends is None:
            return
        unknown = [f for f in self.frontends if f not in FRONTENDS]
        if unknown:
            raise ValueError(f"frontends: unknown front end {unknown[0]!r} (valid: {', '.join(FRONTENDS)})")
        if len(self.frontends) < 2 or len(set(self.frontends)) != len(self.frontends):
            raise ValueError(f"frontends: at least two distinct front ends, got {self.frontends}")

    def _check_power(self) -> None:
        """Every level the power plan names is planned with at least the worlds it needs."""
        if self.power is None:
            return
        unknown = sorted(set(self.power.worlds) - set(self.levels))
        if unknown:
            raise ValueError(f"power.worlds: unknown level {unknown[0]!r} (levels: {', '.join(self.levels)})")
        for level, need in self.power.worlds.items():
            n = self.worlds_needed(level) if self.adds_seeds else len(self.seeds)
            if n < need:
                raise ValueError(
                    f"levels.{level}: planned with {n} worlds, but its power plan needs {need} (a paired difference "
                    f"of recall of {self.power.effect:g} detected with power {POWER:g}, from {self.power.pilot}); "
                    "allowed: "
                    f"min_worlds.{level} (and max_seeds) of at least {need}"
                )

    def worlds_needed(self, level: str) -> int:
        """The fewest worlds (seeds) ``level`` is planned with (``min_worlds``; 1 when not given)."""
        if isinstance(self.min_worlds, dict):
            return self.min_worlds.get(level, 1)
        return 1 if self.min_worlds is None else self.min_worlds

    @property
    def adds_seeds(self) -> bool:
        """Whether seeds are added per level (``min_worlds`` or ``min_relevant_per_bin``) instead of fixed."""
        return self.min_worlds is not None or self.min_relevant_per_bin is not None

    def level_done(self, level: str, worlds: int, relevant: list[int]) -> bool:
        """Whether ``level`` with ``worlds`` planned worlds and ``relevant`` pairs per bin needs no more seeds."""
        if worlds >= self.max_seeds:
            return True
        enough = self.min_relevant_per_bin is None or min(relevant) >= self.min_relevant_per_bin
        return enough and worlds >= self.worlds_needed(level)

    def heading_edges(self) -> list[float]:
        """Heading bin edges from 0 to 180 deg."""
        n = int(round(180.0 / self.heading_bin_deg))
        return [i * self.heading_bin_deg for i in range(n)] + [180.0]

    def scene_at(self, level: str, methods: list[str], overrides: list[str]) -> CrossingScene:
        """The scene of ``level`` scoring ``methods``, with the suite's and the given overrides."""
        data = self.scene.model_dump(mode="json")
        data.update(ambiguity=self.levels[level], methods=list(methods), overrides=[*self.scene.overrides, *overrides])
        return validate_model(CrossingScene, data, source=f"suite {self.name}: scene")


SUITES: Registry[BenchmarkSuite] = Registry("benchmark suite")
SUITES.register(
    "quick",
    BenchmarkSuite(
        name="quick",
        description="a first look and CI: one small crossing scene per ambiguity level, three methods",
        scene=CrossingScene(robots=5, length_m=40.0, site_radius_m=6.0, extent_m=64.0, render_rgb=False),
        seeds=[0],
        methods=["roman", "clipper", "ransac100k"],
    ),
)
SUITES.register(
    "standard",
    BenchmarkSuite(
        name="standard",
        description=(
            "22 / 20 / 16 / 12 / 8 worlds at ambiguity index about 0.05 / 0.15 / 0.30 / 0.45 / 0.85, 320 x 240"
            " colour images, 60 deg bins: paired verdicts planned to detect a difference of held-out recall of"
            " 0.10 with power 0.8 (0.05 would need four times the worlds, about 4 h on 2 cores)"
        ),
        scene=CrossingScene(
            robots=8, length_m=40.0, site_radius_m=6.0, extent_m=64.0, image_width=320, image_height=240
        ),
        levels=dict(STANDARD_LEVELS),
        heading_bin_deg=60.0,
        min_worlds=dict(STANDARD_WORLDS),
        min_relevant_per_bin=100,
        max_seeds=40,
        power=PowerPlan(worlds=dict(STANDARD_WORLDS), effect=0.1, pilot=STANDARD_PILOT),
    ),
)


SUITES.register(
    "envelope",
    BenchmarkSuite(
        name="envelope",
        description=(
            "the standard levels with 4 worlds each, run with the simulated, paper-calibrated and image front"
            " ends: which verdicts hold for every front end"
        ),
        scene=CrossingScene(
            robots=8, length_m=40.0, site_radius_m=6.0, extent_m=64.0, image_width=320, image_height=240
        ),
        levels=dict(STANDARD_LEVELS),
        heading_bin_deg=60.0,
        min_worlds=4,
        frontends=["simulated", "paper", "image"],
    ),
)


def load_suite(name_or_path: str | Path) -> BenchmarkSuite:
    """A built-in suite by name, or a suite YAML file (ConfigError names the valid suites)."""
    p = Path(name_or_path)
    if str(name_or_path) not in SUITES and p.suffix in (".yaml", ".yml"):
        if not p.is_file():
            raise ConfigError(f"benchmark suite {str(name_or_path)!r}: no such file")
        return validate_model(BenchmarkSuite, read_yaml(p), source=str(p))
    if str(name_or_path) not in SUITES:
        raise ConfigError(
            f"unknown benchmark suite {str(name_or_path)!r} (valid: {', '.join(SUITES.names())}, or a suite YAML file)"
        )
    return SUITES.get(str(name_or_path))


def check_methods(methods: list[str]) -> list[str]:
    """``methods`` if each is a registered aligner or an importable ``package.module:Class``.

    A method's row in every table is its label (``pipeline.scenario.method_label``: a plug-in's
    class name), so two methods may not share one.

    Raises:
        ConfigError: an empty list, a duplicate, an unknown method (naming it and the valid ones),
            or two methods with one label.
    """
    from roman_sim.align import ALIGNERS

    if not methods:
        raise ConfigError("--methods: give at least one method")
    dup = sorted({m for m in methods if methods.count(m) > 1})
    if dup:
        raise ConfigError(f"--methods: {', '.join(dup)} given twice")
    for m in methods:
        if ":" in m:
            import_object(m, "aligner")
        elif m not in ALIGNERS:
            raise ConfigError(
                f"--methods: unknown method {m!r} (valid: {', '.join(ALIGNERS.names())}, or package.module:Class)"
            )
    rows: dict[str, str] = {}
    for m in methods:
        other = rows.setdefault(method_label(m), m)
        if other != m:
            raise ConfigError(
                f"--methods: {other} and {m} would share the row {method_label(m)!r} "
                "(a plug-in's row is its class name: rename one class)"
            )
    return list(methods)
