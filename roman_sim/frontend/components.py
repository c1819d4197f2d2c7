"""The front end's configuration: named segmenters and encoders with ``params``, and factories.

A segmenter or encoder is an entry ``{name: ..., params: {...}}`` (a bare name is accepted)
naming a registered component or a user class ``package.module:Class``. Each registered
component declares whether it needs RGB and whether it reads ground truth, so a run can
check its robots before anything renders and give truth only to the components that read
it. Built-in segmenters: ``perfect`` and ``fastsam`` (truth masks, degraded by the error
model of ``SegmenterConfig``), ``image`` (RGB + depth only) and ``sam`` (a local SAM model);
built-in encoders: ``simulated`` (from the true family and each instance's looks), ``image`` (colour and texture
statistics), ``clip`` and ``dinov2`` (local models). A user class may set the class
attributes ``needs_rgb`` and ``reads_truth`` (both False when absent).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, cast

from pydantic import Field, ValidationInfo, field_validator, model_validator

from roman_sim.core.config import StrictModel, validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.registry import Registry, import_object
from roman_sim.frontend.appearance import SceneLooks
from roman_sim.frontend.semantics import SemanticConfig
from roman_sim.mapping.protocols import Segmenter, SemanticEncoder

if TYPE_CHECKING:
    from roman_sim.frontend.image_encoder import ImageEncoderConfig
    from roman_sim.frontend.image_segmenter import ImageSegmenterConfig
    from roman_sim.frontend.models.config import ClipConfig, Dinov2Config, ModelConfig, SamConfig


class RobotRGB(Protocol):
    """What ``check_robots`` reads of a robot."""

    @property
    def name(self) -> str: ...

    @property
    def render_rgb(self) -> bool: ...


@dataclass(frozen=True)
class BuildContext:
    """What a factory may use: the scenario seed, the robot, and truth for truth-driven components."""

    seed: int
    robot: str
    families: Mapping[int, str] | None
    semantics: SemanticConfig
    looks: SceneLooks | None = None


@dataclass(frozen=True)
class ComponentSpec:
    """A registered segmenter or encoder.

    Attributes:
        build: ``build(params, ctx) -> component`` (``params`` validated by ``params_model``).
        params_model: the component's parameter model.
        needs_rgb: the component reads ``frame.rgb`` (robots must render it).
        reads_truth: the component reads ground truth (object ids, families).
        description: one line for listings.
        check: ``check(params)`` raises ``ConfigError`` for what can fail before any work
            (a model folder that is not there), without building the component.
    """

    # the factory's first argument is its own parameter model (a user class: the raw dict)
    build: Callable[[Any, BuildContext], object]
    params_model: type[StrictModel]
    needs_rgb: bool
    reads_truth: bool
    description: str = ""
    check: Callable[[Any], None] | None = None


class NoParams(StrictModel):
    """A component without parameters."""


#: Registered segmenters (entries in ``frontend.segmenter``).
SEGMENTER_TYPES: Registry[ComponentSpec] = Registry("segmenter")
#: Registered semantic encoders (entries in ``frontend.encoder``).
ENCODER_TYPES: Registry[ComponentSpec] = Registry("encoder")


class ComponentEntry(StrictModel):
    """A named component and its parameters; a bare string is read as ``{name: string}``."""

    name: str = Field(..., min_length=1)
    params: dict[str, object] = Field(default_factory=dict)

    @model_validator(mode="before")
    @classmethod
    def _bare_name(cls, v: object) -> object:
        if isinstance(v, str):
            return {"name": v}
        if not isinstance(v, dict):
            raise ValueError(f"expected a string or a mapping {{name: ..., params: {{...}}}}, got {type(v).__name__}")
        return v


class SegmenterEntry(ComponentEntry):
    """``frontend.segmenter``: a registered segmenter or ``package.module:Class``."""

    name: str = Field("fastsam", min_length=1)

    @model_validator(mode="before")
    @classmethod
    def _error_model_fields(cls, v: object) -> object:
        """A mapping of ``SegmenterConfig`` fields alone (the older form) is the fastsam model's params."""
        if isinstance(v, dict) and v and not ({"name", "params"} & set(v)):
            return {"name": "fastsam", "params": v}
        return v

    @model_validator(mode="after")
    def _known(self) -> SegmenterEntry:
        _check_entry(SEGMENTER_TYPES, self, "frontend.segmenter")
        return self


class EncoderEntry(ComponentEntry):
    """``frontend.encoder``: a registered encoder or ``package.module:Class``."""

    name: str = Field("simulated", min_length=1)

    @model_validator(mode="after")
    def _known(self) -> EncoderEntry:
        _check_entry(ENCODER_TYPES, self, "frontend.encoder")
        return self


def _check_entry(registry: Registry[ComponentSpec], entry: ComponentEntry, field: str) -> None:
    """Unknown names and bad built-in parameters fail when the configuration loads."""
    if ":" in entry.name:
        return
    if entry.name not in registry:
        raise ValueError(
            f"unknown {registry.kind} {entry.name!r} (valid: {', '.join(registry.names())}, or package.module:Class)"
        )
    validate_model(registry.get(entry.name).params_model, entry.params, source=f"{field}.params")


class FrontEndConfig(StrictModel):
    """Segmenter and semantic encoder (built-in or ``package.module:Class``, each with ``params``).

    ``semantics`` parameterises the ``simulated`` encoder (``roman-sim calibrate`` fits it).
    ``preset`` puts a bundled preset (``paper``) or a YAML file's ``frontend`` section under
    these fields, and ``severity`` scales the error parameters when components are built
    (``roman_sim.frontend.presets``).
    """

    preset: str | None = Field(None, description="bundled preset name or YAML file under these fields")
    severity: float = Field(1.0, ge=0, le=10, description="scales the simulated error parameters when built")
    segmenter: SegmenterEntry = Field(default_factory=SegmenterEntry)
    encoder: EncoderEntry = Field(default_factory=EncoderEntry)
    semantics: SemanticConfig = Field(default_factory=SemanticConfig)

    @model_validator(mode="before")
    @classmethod
    def _preset(cls, v: Any) -> Any:
        from roman_sim.frontend.presets import with_preset

        return with_preset(v) if isinstance(v, dict) else v

    @field_validator("semantics")
    @classmethod
    def _switches_honoured(cls, v: SemanticConfig, info: ValidationInfo) -> SemanticConfig:
        """A simulated mechanism switched off on an encoder that has none is an error, not a no-op."""
        off, encoder = v.switched_off(), info.data.get("encoder")
        if off and isinstance(encoder, EncoderEntry) and encoder.name != "simulated":
            raise ValueError(
                f"{off[0]}: false is allowed only with the simulated encoder (encoder {encoder.name!r} "
                f"has no simulated {off[0].replace('_', ' ')}); allowed: true"
            )
        return v

    def built_semantics(self) -> SemanticConfig:
        """``semantics`` at this ``severity``: the confusion level scaled (clipped to the largest it allows)."""
        if self.severity == 1.0:
            return self.semantics
        conf = self.semantics.confusion
        level = min(conf.level * self.severity, conf.max_level())
        return self.semantics.model_copy(update={"confusion": conf.model_copy(update={"level": level})})

    def built_segmenter(self) -> SegmenterEntry:
        """``segmenter`` at this ``severity`` (the simulated segmenter's rates scaled)."""
        if self.severity == 1.0:
            return self.segmenter
        from roman_sim.frontend.presets import scaled_segmenter_params

        params = scaled_segmenter_params(self.segmenter.name, self.segmenter.params, self.severity)
        return self.segmenter.model_copy(update={"params": params})

    @property
    def needs_rgb(self) -> bool:
        """Whether the segmenter or the encoder reads RGB."""
        return segmenter_spec(self.segmenter).needs_rgb or encoder_spec(self.encoder).needs_rgb

    @property
    def reads_truth(self) -> bool:
        """Whether the segmenter or the encoder reads ground truth."""
        return segmenter_spec(self.segmenter).reads_truth or encoder_spec(self.encoder).reads_truth


def _user_spec(name: str, kind: str) -> ComponentSpec:
    cls = import_object(name, kind)
    if not callable(cls):
        raise ConfigError(f"{kind} {name!r}: not callable")

    def build(params: dict[str, object], ctx: BuildContext) -> object:
        try:
            return cls(**params)
        except TypeError as err:
            raise ConfigError(f"{kind} {name!r}: cannot construct it with params {sorted(params)} ({err})") from None

    return ComponentSpec(
        build, NoParams, bool(getattr(cls, "needs_rgb", False)), bool(getattr(cls, "reads_truth", False)), "user class"
    )


def segmenter_spec(entry: ComponentEntry | str) -> ComponentSpec:
    """The ``ComponentSpec`` of a segmenter entry (user classes are imported, not built)."""
    name = entry if isinstance(entry, str) else entry.name
    return _user_spec(name, "segmenter") if ":" in name else SEGMENTER_TYPES.get(name)


def encoder_spec(entry: ComponentEntry | str) -> ComponentSpec:
    """The ``ComponentSpec`` of an encoder entry (user classes are imported, not built)."""
    name = entry if isinstance(entry, str) else entry.name
    return _user_spec(name, "semantic encoder") if ":" in name else ENCODER_TYPES.get(name)


def _build(spec: ComponentSpec, entry: ComponentEntry, ctx: BuildContext, field: str) -> object:
    if spec.params_model is NoParams and ":" in entry.name:
        return spec.build(dict(entry.params), ctx)
    params = validate_model(spec.params_model, entry.params, source=f"{field}.params")
    return spec.build(params, ctx)


def _entry(
    cfg: FrontEndConfig | ComponentEntry | str | dict[str, object], cls: type[ComponentEntry], field: str
) -> ComponentEntry:
    if isinstance(cfg, FrontEndConfig):
        return cfg.built_segmenter() if field.endswith("segmenter") else cfg.encoder
    if isinstance(cfg, ComponentEntry):
        return cfg
    return validate_model(cls, {"name": cfg} if isinstance(cfg, str) else cfg, source=field)


def build_segmenter(
    cfg: FrontEndConfig | ComponentEntry | str | dict[str, object], seed: int = 0, robot: str = ""
) -> Segmenter:
    """The configured segmenter of ``robot`` (any object with ``segment(frame) -> list[Mask]``).

    ``cfg`` is a front end, an entry, a name or an entry's dict.
    """
    entry = _entry(cfg, SegmenterEntry, "frontend.segmenter")
    ctx = BuildContext(seed, robot, None, SemanticConfig())
    return cast(Segmenter, _build(segmenter_spec(entry), entry, ctx, "frontend.segmenter"))


def build_encoder(
    cfg: FrontEndConfig | ComponentEntry | str | dict[str, object],
    seed: int = 0,
    robot: str = "",
    families: Mapping[int, str] | None = None,
    looks: SceneLooks | None = None,
) -> SemanticEncoder:
    """The configured semantic encoder of ``robot``.

    Args:
        cfg: the front end (its ``semantics`` parameterise ``simulated``), an entry, a name
            or an entry's dict.
        seed: scenario seed (the simulated encoder's prototypes are shared by all robots).
        robot: robot name (keys the simulated encoder's observation noise).
        families: object id -> family, for truth-driven encoders only.
        looks: how the world draws its objects and the robot's light (the simulated encoder's
            appearance, view and light terms; ``roman_sim.interop.looks.robot_looks``).
    """
    semantics = cfg.built_semantics() if isinstance(cfg, FrontEndConfig) else SemanticConfig()
    entry = _entry(cfg, EncoderEntry, "frontend.encoder")
    spec = encoder_spec(entry)
    truth = spec.reads_truth
    ctx = BuildContext(seed, robot, families if truth else None, semantics, looks if truth else None)
    return cast(SemanticEncoder, _build(spec, entry, ctx, "frontend.encoder"))


def check_robots(frontend: FrontEndConfig, robots: Iterable[RobotRGB]) -> None:
    """Raise ``ConfigError`` naming the first robot (``.name``, ``.render_rgb``) without the RGB the front end needs."""
    if not frontend.needs_rgb:
        return
    specs = (("segmenter", segmenter_spec(frontend.segmenter)), ("encoder", encoder_spec(frontend.encoder)))
    which = [n for n, s in specs if s.needs_rgb]
    for r in robots:
        if not r.render_rgb:
            names = " and ".join(f"{w} {getattr(frontend, w).name!r}" for w in which)
            verb = "need" if len(which) > 1 else "needs"
            raise ConfigError(
                f"robots.{r.name}.render_rgb: the front end's {names} {verb} RGB images; "
                f"set render_rgb: true for robot {r.name!r}"
            )


def check_frontend(frontend: FrontEndConfig, robots: Iterable[RobotRGB]) -> None:
    """``check_robots``, then each built-in component's own check (model folders), building nothing."""
    check_robots(frontend, robots)
    for entry, spec, field in (
        (frontend.segmenter, segmenter_spec(frontend.segmenter), "frontend.segmenter"),
        (frontend.encoder, encoder_spec(frontend.encoder), "frontend.encoder"),
    ):
        if spec.check is not None and ":" not in entry.name:
            spec.check(validate_model(spec.params_model, entry.params, source=f"{field}.params"))


# Built-in components. Factories import their modules on use, so that loading a configuration
# never imports an optional model library.


def _simulated_segmenter(preset: str) -> Callable[[StrictModel, BuildContext], Segmenter]:
    def build(params: StrictModel, ctx: BuildContext) -> Segmenter:
        from roman_sim.frontend.segmenter import SEGMENTERS, SegmenterConfig, SimulatedSegmenter

        base = SEGMENTERS.get(preset).model_dump()
        base.update({k: getattr(params, k) for k in params.model_fields_set})
        return SimulatedSegmenter(validate_model(SegmenterConfig, base, source="frontend.segmenter.params"), ctx.seed)

    return build


def _image_segmenter(params: ImageSegmenterConfig, ctx: BuildContext) -> Segmenter:
    from roman_sim.frontend.image_segmenter import ImageSegmenter

    return ImageSegmenter(params)


def _sam_segmenter(params: SamConfig, ctx: BuildContext) -> Segmenter:
    from roman_sim.frontend.models.sam import SamSegmenter

    return SamSegmenter(params)


def _simulated_encoder(params: StrictModel, ctx: BuildContext) -> SemanticEncoder:
    from roman_sim.frontend.semantics import SimulatedEncoder

    return SimulatedEncoder(ctx.semantics, seed=ctx.seed, families=ctx.families, robot=ctx.robot, looks=ctx.looks)


def _image_encoder(params: ImageEncoderConfig, ctx: BuildContext) -> SemanticEncoder:
    from roman_sim.frontend.image_encoder import ImageEncoder

    return ImageEncoder(params)


def _clip_encoder(params: ClipConfig, ctx: BuildContext) -> SemanticEncoder:
    from roman_sim.frontend.models.clip import ClipEncoder

    return ClipEncoder(params)


def _dinov2_encoder(params: Dinov2Config, ctx: BuildContext) -> SemanticEncoder:
    from roman_sim.frontend.models.dinov2 import Dinov2Encoder

    return Dinov2Encoder(params)


def _weights_check(field: str, model_types: tuple[str, ...]) -> Callable[[ModelConfig], None]:
    def check(params: ModelConfig) -> None:
        from roman_sim.frontend.models.common import weights_dir

        weights_dir(params.weights, field, model_types)

    return check


def _register_builtins() -> None:
    from roman_sim.frontend.image_encoder import ImageEncoderConfig
    from roman_sim.frontend.image_segmenter import ImageSegmenterConfig
    from roman_sim.frontend.models.config import ClipConfig, Dinov2Config, SamConfig
    from roman_sim.frontend.segmenter import SegmenterConfig

    seg, enc = SEGMENTER_TYPES.register, ENCODER_TYPES.register
    seg(
        "perfect",
        ComponentSpec(
            _simulated_segmenter("perfect"),
            SegmenterConfig,
            False,
            True,
            "true instance masks, ROMAN's area filter and erosion only",
        ),
    )
    seg(
        "fastsam",
        ComponentSpec(
            _simulated_segmenter("fastsam"),
            SegmenterConfig,
            False,
            True,
            "true instance masks degraded by FastSAM-like errors (SegmenterConfig)",
        ),
    )
    seg(
        "image",
        ComponentSpec(
            _image_segmenter, ImageSegmenterConfig, True, False, "colour regions cut and joined by depth (no truth)"
        ),
    )
    seg(
        "sam",
        ComponentSpec(
            _sam_segmenter,
            SamConfig,
            True,
            False,
            "Segment Anything automatic masks (local weights, transformers)",
            _weights_check("frontend.segmenter.params.weights", ("sam",)),
        ),
    )
    enc(
        "simulated",
        ComponentSpec(
            _simulated_encoder,
            NoParams,
            False,
            True,
            "CLIP-like descriptors from the true family and looks (frontend.semantics)",
        ),
    )
    enc(
        "image",
        ComponentSpec(
            _image_encoder,
            ImageEncoderConfig,
            True,
            False,
            "colour and texture statistics of the mask's crop (no truth)",
        ),
    )
    enc(
        "clip",
        ComponentSpec(
            _clip_encoder,
            ClipConfig,
            True,
            False,
            "CLIP image embedding of the mask's box crop (local weights)",
            _weights_check("frontend.encoder.params.weights", ("clip", "clip_vision_model")),
        ),
    )
    enc(
        "dinov2",
        ComponentSpec(
            _dinov2_encoder,
            Dinov2Config,
            True,
            False,
            "DINOv2 patch features averaged over the mask (local weights)",
            _weights_check("frontend.encoder.params.weights", ("dinov2",)),
        ),
    )


_register_builtins()
