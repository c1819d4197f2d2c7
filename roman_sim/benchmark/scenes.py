"""The crossing scene: many robots cross one shared site at headings spread over the circle.

A crossing scene is a square world of the off-road preset, made dense as in the demo (each
submap holds 10-40 segments), whose ambiguity knob is set to one level, and ``robots``
straight drives of ``length_m`` through a site at the world centre. Robot k drives at
heading ``(k + u_k) * 360 / robots`` plus one common rotation (stratified with seeded
jitter ``u_k`` in [0, 1)) through a point drawn uniformly in the site disc of radius
``site_radius_m``; the planner routes each drive around the objects in its way. Every pair
of robots therefore crosses once, and the heading differences of the pairs fill 0-180 deg
evenly, so every 30 deg bin gets relevant pairs from one world. A drive that cannot be
routed or driven is drawn again through another point of the site (the heading stays).

``build_crossing`` generates the world, chooses the drives, drives them (no rendering) and
returns the scenario with the truth of every pair its run will score
(``plan``), so relevant counts are known before anything is rendered. The same
inputs give the same scenario. ``overrides`` are dotted scenario overrides applied on top:
the realism options of the world, the robots and the front end pass through this way
(e.g. ``frontend.semantics.dim=512`` or ``world.overrides.appearance.lighting=random``).
Randomness comes from the seed only (``child_rng(seed, "crossing", ...)``).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from roman_sim.benchmark.plan import scored_pairs, submaps_along
from roman_sim.core.config import FiniteTree, StrictModel, apply_overrides, validate_model
from roman_sim.core.errors import SimError
from roman_sim.core.seeding import child_rng
from roman_sim.evaluation.pairs import PairTruth, world_ambiguity_fn
from roman_sim.pipeline.scenario import Scenario
from roman_sim.sim.odometry import DRIFT_PRESETS

log = logging.getLogger(__name__)

#: The base world: the off-road preset, dense and uniform (objects per hectare per family).
BASE_WORLD: dict[str, FiniteTree] = {
    "layout.kind": "uniform",
    "families.0.density": 120,  # boulder
    "families.1.density": 150,  # bush
    "families.2.density": 80,  # conifer
    "families.3.density": 40,  # deciduous
    "families.4.density": 20,  # log
    "families.5.density": 20,  # stump
    "appearance.textures": True,  # surfaces the visual method's ORB features can use
}
#: Clear margin (m) between a drive's ends and the world's edge.
EDGE_MARGIN_M = 2.0
#: Draws of a drive's site point before the scene is given up.
MAX_ATTEMPTS = 20


class CrossingScene(StrictModel):
    """One crossing scene (world, robots, drives); see the module docstring."""

    robots: int = Field(10, ge=2, le=200, description="robots, each driving once through the site")
    length_m: float = Field(50.0, gt=5.0, le=1000.0, description="length of each straight drive")
    site_radius_m: float = Field(10.0, ge=0.0, le=500.0, description="drives pass through points of this disc")
    extent_m: float = Field(80.0, gt=10.0, le=2000.0, description="side of the square world")
    ambiguity: float = Field(0.0, ge=0.0, le=1.0, description="the world's ambiguity knob")
    drift: str = Field("typical", description="odometry drift preset of every robot")
    image_width: int = Field(320, ge=16, le=4096)
    image_height: int = Field(240, ge=16, le=4096)
    render_rgb: bool = Field(True, description="render colour images (the visual method and image front ends)")
    methods: list[str] = Field(default_factory=lambda: ["roman"], min_length=1, description="aligners")
    overrides: list[str] = Field(default_factory=list, description="dotted scenario overrides applied last")

    @model_validator(mode="after")
    def _check(self) -> "CrossingScene":
        if self.drift not in DRIFT_PRESETS:
            raise ValueError(f"drift: unknown preset {self.drift!r} (valid: {', '.join(DRIFT_PRESETS.names())})")
        reach = self.site_radius_m + self.length_m / 2 + EDGE_MARGIN_M
        if reach > self.extent_m / 2:
            raise ValueError(
                f"extent_m: {self.extent_m:g} m is too small for drives of {self.length_m:g} m through a site of "
                f"radius {self.site_radius_m:g} m (needs at least {2 * reach:g} m)"
            )
        return self


def headings_deg(scene: CrossingScene, seed: int) -> NDArray[np.float64]:
    """The robots' drive headings (deg, in [0, 360)): stratified over the circle with seeded jitter."""
    rng = child_rng(seed, "crossing", "headings")
    k = scene.robots
    return ((np.arange(k) + rng.uniform(0.0, 1.0, k)) * (360.0 / k) + rng.uniform(0.0, 360.0)) % 360.0


def drive_ends(scene: CrossingScene, seed: int, robot: int, heading_deg: float, attempt: int) -> NDArray[np.float64]:
    """(2, 2) start and end of a robot's drive through a point of the site (one draw per attempt)."""
    rng = child_rng(seed, "crossing", "site", robot, attempt)
    r = scene.site_radius_m * np.sqrt(rng.uniform(0.0, 1.0))
    a = rng.uniform(0.0, 2 * np.pi)
    u = np.array([np.cos(np.radians(heading_deg)), np.sin(np.radians(heading_deg))])
    c = r * np.array([np.cos(a), np.sin(a)])
    return np.vstack([c - u * scene.length_m / 2, c + u * scene.length_m / 2])


def robot_name(i: int) -> str:
    """``r00``, ``r01``, ...: names sort in robot order."""
    return f"r{i:02d}" if i < 100 else f"r{i}"


def _robot(scene: CrossingScene, i: int, ends: NDArray[np.float64]) -> dict[str, Any]:
    return {
        "name": robot_name(i),
        "path": {"kind": "waypoints", "waypoints": [[float(x), float(y)] for x, y in ends]},
        "camera": {"width": scene.image_width, "height": scene.image_height},
        "render_rgb": scene.render_rgb,
        "drift": scene.drift,
    }


def scenario_data(scene: CrossingScene, seed: int, ends: list[NDArray[np.float64]], name: str) -> dict[str, Any]:
    """The scenario of ``scene`` at ``seed`` with the given drives, as data (before the overrides)."""
    return {
        "name": name,
        "description": f"crossing scene: {scene.robots} robots through one site, ambiguity knob {scene.ambiguity:g}",
        "seed": int(seed),
        "world": {
            "preset": "offroad",
            "overrides": {"extent_m": [scene.extent_m, scene.extent_m], **BASE_WORLD, "ambiguity": scene.ambiguity},
        },
        "robots": [_robot(scene, i, e) for i, e in enumerate(ends)],
        "aligners": list(scene.methods),
        "posegraph_method": "roman" if "roman" in scene.methods else None,
    }


#: Overrides of the world's specification: kept as one dotted key of ``world.overrides``.
WORLD_PREFIX = "world.overrides."


def with_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """``data`` with dotted overrides applied; ``world.overrides.<a.b>=v`` sets the world spec field ``a.b``
    (as the scenario's own ``world.overrides`` keys do), every other key is a path into the scenario."""
    world = [o[len(WORLD_PREFIX) :] for o in overrides if o.startswith(WORLD_PREFIX)]
    out = apply_overrides(data, [o for o in overrides if not o.startswith(WORLD_PREFIX)])
    for item in world:
        key, _, raw = item.partition("=")
        parsed = apply_overrides({"value": None}, [f"value={raw}"])["value"]
        out["world"]["overrides"][key.strip()] = parsed
    return out


def _scenario(scene: CrossingScene, seed: int, ends: list[NDArray[np.float64]], name: str) -> Scenario:
    data = with_overrides(scenario_data(scene, seed, ends, name), list(scene.overrides))
    return validate_model(Scenario, data, source=f"benchmark scene {name}")


@dataclass
class CrossingPlan:
    """A crossing scenario, the truth of every pair its run will score (relevance by distance) and
    the length of its driven trajectories (km)."""

    scenario: Scenario
    truths: list[PairTruth]
    trajectory_km: float


def build_crossing(scene: CrossingScene, seed: int, name: str = "crossing", ambiguity: bool = False) -> CrossingPlan:
    """The scenario of ``scene`` at ``seed`` with drives that route and drive, and its planned pairs.

    With ``ambiguity`` each planned pair carries its place's ground-truth ambiguity, as the
    evaluation stage computes it (the mean over the two true submap centres, discs of the
    submap radius), so a level's measured ambiguity index is known before anything is rendered.

    Raises:
        ConfigError: an override or the scene is invalid (names the field).
        SimError: a robot's drive could not be placed in ``MAX_ATTEMPTS`` draws.
    """
    from roman_sim.sim.source import robot_sources
    from roman_sim.world import generate_truth

    heads = headings_deg(scene, seed)
    ends = [drive_ends(scene, seed, i, float(h), 0) for i, h in enumerate(heads)]
    sc = _scenario(scene, seed, ends, name)
    world = generate_truth(sc.world.spec(), seed)
    runs = {}
    for i, h in enumerate(heads):
        for attempt in range(MAX_ATTEMPTS):
            if attempt:
                ends[i] = drive_ends(scene, seed, i, float(h), attempt)
                sc = _scenario(scene, seed, ends, name)
            cfg = sc.robots[i]
            try:
                runs[cfg.name] = robot_sources(world, [cfg], seed)[0].run  # each drive on its own
                break
            except SimError as err:
                log.debug("%s: drive %d of robot %s rejected (%s)", name, attempt, cfg.name, err)
        else:
            raise SimError(f"{name}: robot {robot_name(i)} found no drive through the site in {MAX_ATTEMPTS} draws")
    subs = submaps_along(runs, sc.submaps)
    km = (
        sum(float(np.linalg.norm(np.diff(r.T_world_body[:, :3, 3], axis=0), axis=1).sum()) for r in runs.values())
        / 1000
    )
    amb = world_ambiguity_fn(world.truth, sc.submaps.submap_radius) if ambiguity else None
    return CrossingPlan(sc, scored_pairs(subs, sc, amb), km)
