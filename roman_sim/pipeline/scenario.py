"""The scenario model: one YAML file describes a whole run, stage by stage.

Every stage's section is that stage's own configuration model (unknown keys are errors),
so the resolved scenario written into each results folder documents the run completely.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field, field_validator, model_validator

from roman_sim.align.gating import GatingConfig
from roman_sim.align.visual.keyframes import KeyframeParams
from roman_sim.core.config import FiniteTree, StrictModel, apply_overrides, read_yaml, stable_hash, validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.evaluation.metrics import EvalConfig
from roman_sim.frontend.components import FrontEndConfig
from roman_sim.interop.odometry_in import OdometryFile
from roman_sim.interop.tum_reader import TumSourceConfig
from roman_sim.mapping.submap import SubmapConfig
from roman_sim.mapping.tracker import MappingConfig
from roman_sim.posegraph import PoseGraphConfig
from roman_sim.sim.robot import RobotConfig

if TYPE_CHECKING:
    from roman_sim.world import WorldSpec

log = logging.getLogger(__name__)

#: Folder of the bundled scenarios (package data; the repository root links to it).
SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"
#: Folder of the bundled sweeps.
SWEEP_DIR = SCENARIO_DIR / "sweeps"


class WorldRef(StrictModel):
    """Which world: a preset (or YAML path) plus overrides of its ``WorldSpec`` fields."""

    preset: str = "offroad"
    overrides: dict[str, FiniteTree] = Field(default_factory=dict)

    def spec(self) -> WorldSpec:
        """The resolved ``WorldSpec`` (overrides validated like the preset itself)."""
        from roman_sim.world import WorldSpec, load_world_spec

        base = load_world_spec(self.preset)
        if not self.overrides:
            return base
        data = base.model_dump(mode="json")
        where = f"world.overrides ({self.preset})"
        data = apply_overrides(data, [f"{k}={_yaml_scalar(v)}" for k, v in self.overrides.items()], source=where)
        return validate_model(WorldSpec, data, source=where)


def _yaml_scalar(v: object) -> str:
    import json

    return json.dumps(v)


class AlignerEntry(StrictModel):
    """One aligner to evaluate: a registered method or ``package.module:Class``."""

    method: str = Field(..., min_length=1)
    label: str | None = Field(None, description="name in tables (default: the method)")
    params: dict[str, FiniteTree] = Field(default_factory=dict)

    @property
    def name(self) -> str:
        """Label in tables: ``label``, else ``method_label(method)``."""
        return self.label or method_label(self.method)


#: Methods that align submaps by their visual keyframes (the maps stage extracts them).
VISUAL_METHODS = frozenset({"visual"})


def method_label(method: str) -> str:
    """Table label of a method name: itself, or the class name of ``package.module:Class``."""
    return method.split(":", 1)[1].rsplit(".", 1)[-1] if ":" in method else method


class FrontEnd(FrontEndConfig):
    """The scenario's front end: segmenter, encoder, the simulated encoder's semantics and visual keyframes."""

    keyframes: KeyframeParams = Field(
        default_factory=KeyframeParams, description="visual keyframes (ORB + BoW), extracted when a method needs them"
    )


class ScenarioRobot(RobotConfig):
    """A robot of a scenario: simulated (the ``RobotConfig`` fields), or read from a recorded
    sequence (``source``: a TUM RGB-D folder; the simulation fields are then unused); either
    kind may take its odometry from a TUM file instead of its own (``odometry``)."""

    source: TumSourceConfig | None = Field(None, description="read this robot from a TUM RGB-D folder")
    odometry: OdometryFile | None = Field(None, description="a TUM trajectory that replaces the robot's odometry")

    omitted_when_absent: ClassVar[tuple[str, ...]] = (*RobotConfig.omitted_when_absent, "odometry")

    @property
    def simulated(self) -> bool:
        """Whether the robot is simulated (no ``source``)."""
        return self.source is None


class Scenario(StrictModel):
    """A complete run: world, robots, front end, submaps, aligners, pose graph, evaluation."""

    name: str = Field(..., min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    seed: int = Field(0, ge=0)
    world: WorldRef = Field(default_factory=WorldRef)
    robots: list[ScenarioRobot] = Field(..., min_length=1)
    frontend: FrontEnd = Field(default_factory=FrontEnd)
    mapping: MappingConfig = Field(default_factory=MappingConfig)
    submaps: SubmapConfig = Field(default_factory=SubmapConfig)
    aligners: list[AlignerEntry] = Field(default_factory=lambda: [AlignerEntry(method="roman")], min_length=1)
    posegraph_method: str | None = Field(
        "roman",
        description="aligner whose loop closures feed the pose graph, by its label or its method "
        "(a plug-in's package.module:Class or class name; None: no pose graph)",
    )
    posegraph: PoseGraphConfig = Field(default_factory=PoseGraphConfig)
    evaluation: EvalConfig = Field(default_factory=EvalConfig)
    gating: GatingConfig = Field(default_factory=GatingConfig, description="submap gating before registration")
    record_frames: bool = Field(False, description="store rendered frames so mapping can re-run without rendering")

    @property
    def uses_visual(self) -> bool:
        """Whether an aligner needs the robots' visual keyframes (the ``visual`` method)."""
        return any(a.method in VISUAL_METHODS for a in self.aligners)

    def simulated_robots(self) -> list[ScenarioRobot]:
        """The robots the simulator renders (those without a ``source``), in order."""
        return [r for r in self.robots if r.simulated]

    @property
    def needs_world(self) -> bool:
        """Whether any robot is simulated (a scenario of recorded sequences needs no world)."""
        return bool(self.simulated_robots())

    def config_hash(self) -> str:
        """Hash of the resolved scenario (what a run folder's ``config.yaml`` holds)."""
        return stable_hash(self.model_dump(mode="json"))

    @field_validator("aligners", mode="before")
    @classmethod
    def _names_to_entries(cls, v: object) -> object:
        if isinstance(v, list):
            return [{"method": x} if isinstance(x, str) else x for x in v]
        return v

    @model_validator(mode="after")
    def _cross_checks(self) -> "Scenario":
        names = [r.name for r in self.robots]
        if len(set(names)) != len(names):
            raise ValueError(f"robots: names must be unique, got {', '.join(names)}")
        labels = [a.name for a in self.aligners]
        if len(set(labels)) != len(labels):
            raise ValueError(f"aligners: labels must be unique, got {', '.join(labels)} (set 'label')")
        by_method = {a.method: a.name for a in self.aligners}
        if self.posegraph_method not in labels and self.posegraph_method in by_method:
            # an aligner named by its method (package.module:Class): its label, without validating again
            self.__dict__["posegraph_method"] = by_method[self.posegraph_method]
        if self.posegraph_method is not None and self.posegraph_method not in labels:
            raise ValueError(f"posegraph_method: {self.posegraph_method!r} is not among aligners ({', '.join(labels)})")
        recorded = {r.name for r in self.robots if not r.simulated}
        for k, r in enumerate(self.robots):
            if r.simulated and r.path.of in recorded:
                raise ValueError(
                    f"robots.{k}.path.of: {r.path.of!r} is read from a TUM folder and has no "
                    "planned path to follow (refer to a simulated robot)"
                )
        if self.uses_visual:
            for i, r in enumerate(self.robots):
                if r.simulated and not r.render_rgb:
                    raise ValueError(
                        f"robots.{i}.render_rgb: robot {r.name!r} must render RGB (render_rgb: true) "
                        "for the visual method"
                    )
        return self


def _missing(entries: list[Any], methods: list[str]) -> list[str]:
    """Those of ``methods`` no entry of a scenario's raw ``aligners`` list runs (names or mappings)."""
    have = {e if isinstance(e, str) else e.get("method") for e in entries if isinstance(e, (str, dict))}
    return [m for m in dict.fromkeys(methods) if m not in have]


def _added(data: dict[str, Any], methods: list[str]) -> dict[str, Any]:
    """Scenario data with the aligners ``methods`` appended (those not already in it; absent: the default's)."""
    if not methods:
        return data
    entries = data.get("aligners")
    if entries is None:
        default = Scenario.model_fields["aligners"].get_default(call_default_factory=True)
        entries = [e.model_dump(mode="json") for e in default]
    if not isinstance(entries, list):
        return data  # not a list: validation names the field
    return {**data, "aligners": [*entries, *({"method": m} for m in _missing(entries, methods))]}


def default_run_dir(sc: Scenario, root: str | Path = "results") -> Path:
    """``results/<scenario>/seed<seed>-<config hash>``: stable, so re-runs reuse stages."""
    return Path(root) / sc.name / f"seed{sc.seed}-{sc.config_hash()[:8]}"


def bundled_scenarios() -> dict[str, Path]:
    """Scenario name -> YAML path of the scenarios shipped with the project."""
    return {p.stem: p for p in sorted(SCENARIO_DIR.glob("*.yaml"))}


def resolve_scenario_path(name_or_path: str | Path, relative_to: Path | None = None) -> Path:
    """A scenario YAML path from a bundled name or a (relative) path."""
    p = Path(name_or_path)
    candidates = [p] + ([relative_to / p] if relative_to is not None and not p.is_absolute() else [])
    for c in candidates:
        if c.is_file():
            return c
    bundled = bundled_scenarios()
    if str(name_or_path) in bundled:
        return bundled[str(name_or_path)]
    for c in candidates:
        if c.is_dir():
            raise ConfigError(
                f"scenario {str(name_or_path)!r}: {c} is a directory, expected a scenario YAML file "
                f"or a bundled name ({', '.join(bundled)})"
            )
    raise ConfigError(
        f"scenario {str(name_or_path)!r}: no such file or bundled scenario (bundled: {', '.join(bundled)})"
    )


def load_scenario(
    name_or_path: str | Path, overrides: list[str] | None = None, aligners: list[str] | None = None
) -> Scenario:
    """Load a scenario by name or path, apply ``key=value`` overrides, add ``aligners`` and validate it.

    The aligners are added before the scenario is validated, so an override may name one
    (``posegraph_method=package.module:Class`` with that plug-in among ``aligners``).
    """
    path = resolve_scenario_path(name_or_path)
    data = read_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level")
    overrides, aligners = list(overrides or []), list(aligners or [])
    if not overrides and not aligners:
        return _resolve_sources(validate_model(Scenario, data, source=str(path)), path.parent)
    try:
        sc = validate_model(Scenario, _added(apply_overrides(data, overrides), aligners), source=str(path))
    except ConfigError:
        _blame_override(data, overrides, path, aligners)
        raise
    return _resolve_sources(sc, path.parent)


def _blame_override(data: dict[str, Any], overrides: list[str], path: Path, aligners: list[str]) -> None:
    """Raise the error naming the file when the file is wrong, else the added aligners when they make it
    wrong, else the first ``--set`` that breaks it."""
    validate_model(Scenario, data, source=str(path))
    validate_model(Scenario, _added(data, aligners), source=f"--aligner {' '.join(aligners)}")
    for i, ov in enumerate(overrides):
        validate_model(Scenario, _added(apply_overrides(data, overrides[: i + 1]), aligners), source=f"--set {ov}")


def _resolve_sources(sc: Scenario, base: Path) -> Scenario:
    """Relative ``source.tum`` folders, object tables and odometry files resolved against the scenario
    file's folder.

    A path that exists there is made absolute, so the run folder's ``config.yaml`` points at
    the same data from anywhere; any other relative path stays relative to the working folder.
    """
    for r in sc.robots:
        for model, names in ((r.source, ("tum", "objects")), (r.odometry, ("file",))):
            for name in names if model is not None else ():
                p = getattr(model, name)
                if p is not None and not p.is_absolute() and (base / p).exists():
                    setattr(model, name, (base / p).resolve())
    return sc


def with_odometry(sc: Scenario, files: dict[str, Path]) -> Scenario:
    """``sc`` with each robot named in ``files`` taking its odometry from that TUM file (``run --odometry``).

    Raises: ConfigError naming a robot the scenario does not have.
    """
    names = [r.name for r in sc.robots]
    for robot, path in files.items():
        if robot not in names:
            raise ConfigError(f"--odometry {robot}={path}: no robot {robot} (robots: {', '.join(names)})")
    robots = []
    for r in sc.robots:
        if r.name in files:
            given = r.odometry or OdometryFile(file=files[r.name])
            r = r.model_copy(update={"odometry": given.model_copy(update={"file": files[r.name], "sha256": None})})
        robots.append(r)
    return sc.model_copy(update={"robots": robots})
