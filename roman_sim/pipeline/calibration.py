"""Calibration runs: measure a segmenter or an encoder on rendered frames of a scenario's world,
then fit the simulated front end (``roman_sim.frontend.fit``) to reproduce it.

The encoder is measured on the true instance masks (the ``perfect`` segmenter), so its
cosine distributions are not mixed with segmentation errors; the segmenter is measured
alone. The result is a YAML file a scenario can use as its front-end preset
(``frontend: {preset: calibration.yaml}``)::

    calibration: {scenario: ..., frames: ..., encoder: clip, dim: 768, segmenter: ...}
    frontend:
      semantics: {dim: 768, confusion: {...}, groups: {...}}   # from an encoder
      segmenter: {name: fastsam, params: {...}}               # from a segmenter

``semantics.dim`` is the measured encoder's dimension: a scenario that sets another one
refuses the file.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import yaml

from roman_sim.core.errors import ConfigError
from roman_sim.core.jsontypes import JSONScalar
from roman_sim.core.records import OMIT_NONE, to_json
from roman_sim.core.sensors import Frame
from roman_sim.evaluation.grader import FrontEndGrader
from roman_sim.evaluation.grades import SEGMENTATION_JSON, DescriptorGrades, GradeConfig, SegmentationGrades
from roman_sim.frontend.appearance import SceneLooks
from roman_sim.frontend.components import FrontEndConfig, SegmenterEntry, build_encoder, build_segmenter, encoder_spec
from roman_sim.frontend.fit import fit_segmenter, fit_semantics
from roman_sim.frontend.segmenter import SegmenterConfig, SimulatedSegmenter
from roman_sim.frontend.semantics import SemanticConfig
from roman_sim.mapping.observation import observe_indexed
from roman_sim.mapping.protocols import Segmenter, SemanticEncoder
from roman_sim.mapping.tracker import MappingConfig

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import Scenario

log = logging.getLogger(__name__)


@dataclass
class CalibrationFrames:
    """Rendered frames of a scenario's robots, the world's object families and how the world draws
    them (under its own light: ``roman_sim.interop.looks``)."""

    frames: list[Frame]
    families: dict[int, str]
    seed: int
    looks: SceneLooks | None = None


def render_calibration_frames(scenario: Scenario, max_frames: int = 120) -> CalibrationFrames:
    """At most ``max_frames`` frames in all (RGB on), spread evenly over each robot's run."""
    from dataclasses import replace

    import numpy as np

    from roman_sim.sim.source import robot_sources
    from roman_sim.world import generate

    if not scenario.simulated_robots():
        raise ConfigError(f"scenario {scenario.name}: calibration renders simulated robots, and it has none")
    world = generate(scenario.world.spec(), scenario.seed)
    sources = robot_sources(world, scenario.simulated_robots(), scenario.seed, rgb=True)
    per_robot = max(1, max_frames // len(sources))
    frames: list[Frame] = []
    for src in sources:
        n = len(src)
        keep = np.unique(np.linspace(0, n - 1, min(per_robot, n)).round().astype(int))
        # numbered within the sample: the simulated segmenter's draws are per frame index
        frames += [replace(f, index=k) for k, f in enumerate(src.frames(keep.tolist()))]
    from roman_sim.interop.looks import robot_looks

    looks = robot_looks(world, "", None, scenario.seed)
    return CalibrationFrames(frames, {o.id: o.family for o in world.truth.objects}, scenario.seed, looks)


def grade_segmenter(
    data: CalibrationFrames, segmenter: Segmenter, cfg: GradeConfig | None = None
) -> SegmentationGrades:
    """Segmentation grades of ``segmenter`` on the frames (truth only for truth-driven segmenters)."""
    grader = FrontEndGrader(data.families, cfg=cfg, seed=data.seed)
    truth = bool(getattr(segmenter, "reads_truth", False))
    for f in data.frames:
        grader.add(f, segmenter.segment(f if truth else f.public()), [])
    return grader.seg


def grade_encoder(
    data: CalibrationFrames, encoder: SemanticEncoder, semantics: SemanticConfig, cfg: GradeConfig | None = None
) -> DescriptorGrades | None:
    """Descriptor grades of ``encoder`` on the true instance masks of the frames."""
    grader = FrontEndGrader(data.families, semantics.group_of, cfg=cfg, seed=data.seed)
    perfect = build_segmenter("perfect", data.seed)
    mapping = MappingConfig()
    for f in data.frames:
        masks = perfect.segment(f)
        observed = observe_indexed(f, masks, mapping, encoder)
        grader.add(f, masks, [(k, o.descriptor) for k, o in observed])
    return grader.descriptor_grades()


@dataclass(frozen=True)
class FittedSegmenter:
    """The fitted segmenter as a front-end entry: the simulated ``fastsam`` with its parameters."""

    name: str
    params: SegmenterConfig


@dataclass(frozen=True)
class FittedFrontEnd:
    """The fitted simulated front end: its semantics and segmenter (those calibrated)."""

    semantics: SemanticConfig | None = field(default=None, metadata=OMIT_NONE)
    segmenter: FittedSegmenter | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class CalibrationRecord:
    """What ``calibrate --grades`` writes: the fitted front end, and the measured and fitted grades."""

    frontend: FittedFrontEnd
    measured_descriptors: DescriptorGrades | None
    fitted_descriptors: DescriptorGrades | None
    measured_segmentation: SegmentationGrades | None = field(metadata=SEGMENTATION_JSON)
    fitted_segmentation: SegmentationGrades | None = field(metadata=SEGMENTATION_JSON)


@dataclass
class Calibration:
    """Measured grades of the target components, the fitted parameters and the fit's own grades."""

    semantics: SemanticConfig | None = None
    segmenter: SegmenterConfig | None = None
    measured_descriptors: DescriptorGrades | None = None
    fitted_descriptors: DescriptorGrades | None = None
    measured_segmentation: SegmentationGrades | None = None
    fitted_segmentation: SegmentationGrades | None = None
    meta: dict[str, JSONScalar] | None = None

    def frontend(self) -> FittedFrontEnd:
        """The fitted parameters as a front-end section."""
        seg = None if self.segmenter is None else FittedSegmenter("fastsam", self.segmenter)
        return FittedFrontEnd(self.semantics, seg)

    def frontend_yaml(self) -> str:
        """The fitted parameters as a front-end preset file: ``calibration`` (what was measured) and ``frontend``."""
        head = {"calibration": self.meta} if self.meta else {}
        return yaml.safe_dump({**head, "frontend": to_json(self.frontend())}, sort_keys=False)

    def record(self) -> CalibrationRecord:
        """Everything measured and fitted, as ``calibrate --grades`` writes it."""
        return CalibrationRecord(
            self.frontend(),
            self.measured_descriptors,
            self.fitted_descriptors,
            self.measured_segmentation,
            self.fitted_segmentation,
        )


def calibrate(
    data: CalibrationFrames,
    frontend: FrontEndConfig,
    encoder: bool = True,
    segmenter: bool = True,
    iterations: int = 4,
    prior_semantics: SemanticConfig | None = None,
    prior_segmenter: SegmenterConfig | None = None,
    target_encoder: SemanticEncoder | None = None,
    target_segmenter: Segmenter | None = None,
) -> Calibration:
    """Measure ``frontend``'s encoder and/or segmenter on ``data`` and fit the simulated ones to them.

    Args:
        data: rendered frames (``render_calibration_frames``).
        frontend: the components to measure (``frontend.semantics`` parameterises a
            ``simulated`` target and supplies the family groups).
        encoder: calibrate the encoder.
        segmenter: calibrate the segmenter.
        iterations: correction rounds of the segmenter fit.
        prior_semantics: starting point of the semantic fit for classes without pairs
            (default: the default ``SemanticConfig`` with ``frontend.semantics``' groups).
        prior_segmenter: starting point of the segmenter fit (default: the ``fastsam``
            preset with the target's mask-filter fields).
        target_encoder: an already built encoder (default: built from ``frontend``; build
            truth-free ones before rendering to fail early on bad weights).
        target_segmenter: an already built segmenter, as ``target_encoder``.
    """
    meta: dict[str, JSONScalar] = {"frames": len(data.frames), "seed": data.seed}
    out = Calibration(meta=meta)
    seed = data.seed
    if encoder:
        truth = encoder_spec(frontend.encoder).reads_truth
        target = target_encoder or build_encoder(
            frontend, seed, "calibration", data.families if truth else None, data.looks
        )
        out.measured_descriptors = grade_encoder(data, target, frontend.semantics)
        meta.update(encoder=frontend.encoder.name)
        if out.measured_descriptors is not None:
            meta.update(dim=out.measured_descriptors.dim)
            prior = prior_semantics or SemanticConfig(groups=frontend.semantics.groups)
            out.semantics = fit_semantics(out.measured_descriptors, prior, data.looks)
            fitted = build_encoder(
                FrontEndConfig(semantics=out.semantics), seed + 1, "calibration-fit", data.families, data.looks
            )
            out.fitted_descriptors = grade_encoder(data, fitted, out.semantics)
    if segmenter:
        target_seg = target_segmenter or build_segmenter(frontend, seed, "calibration")
        meta.update(segmenter=frontend.segmenter.name)
        out.measured_segmentation = grade_segmenter(data, target_seg)

        def grade(cfg: SegmenterConfig) -> SegmentationGrades:
            return grade_segmenter(data, SimulatedSegmenter(cfg, seed + 1))

        width = int(data.frames[0].depth.shape[1]) if data.frames else 640
        out.segmenter = fit_segmenter(
            out.measured_segmentation, grade, prior_segmenter or _prior(frontend.segmenter), iterations, width
        )
        out.fitted_segmentation = grade(out.segmenter)
    return out


def _prior(entry: SegmenterEntry) -> SegmenterConfig:
    """The fastsam preset, with the target's own mask-filter fields when it has them."""
    keep = {k: v for k, v in entry.params.items() if k in ("min_area_div", "max_area_div", "erosion_px")}
    return SegmenterConfig(**keep)
