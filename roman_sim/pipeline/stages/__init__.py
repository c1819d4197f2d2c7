"""The pipeline's stages, in order: world -> maps -> submaps -> evaluation -> posegraph -> ate -> report.

Adding a stage is one module (its input dataclass, its output dataclass and a ``Stage``
subclass; the contract is in ``roman_sim.pipeline.stages.base``) plus one line here.
"""

from __future__ import annotations

from roman_sim.pipeline.stages.ate import AteOutput, AteStage
from roman_sim.pipeline.stages.base import Stage, StageOutput
from roman_sim.pipeline.stages.evaluation import EvaluationOutput, EvaluationStage
from roman_sim.pipeline.stages.maps import Maps, MapsStage
from roman_sim.pipeline.stages.posegraph import PoseGraphOutput, PoseGraphStage
from roman_sim.pipeline.stages.report import ReportOutput, ReportStage
from roman_sim.pipeline.stages.submaps import Submaps, SubmapsStage
from roman_sim.pipeline.stages.world import WorldOutput, WorldStage

#: The stage table (order = execution order; every stage's inputs come earlier).
STAGES: tuple[Stage, ...] = (
    WorldStage(),
    MapsStage(),
    SubmapsStage(),
    EvaluationStage(),
    PoseGraphStage(),
    AteStage(),
    ReportStage(),
)
STAGE_NAMES: tuple[str, ...] = tuple(s.name for s in STAGES)
#: What a run's workers import, every stage's ``worker_preload`` in stage order (each entry once).
WORKER_PRELOAD: tuple[str, ...] = tuple(dict.fromkeys(m for s in STAGES for m in s.worker_preload))

__all__ = [
    "STAGES",
    "STAGE_NAMES",
    "WORKER_PRELOAD",
    "AteOutput",
    "EvaluationOutput",
    "Maps",
    "PoseGraphOutput",
    "ReportOutput",
    "Stage",
    "StageOutput",
    "Submaps",
    "WorldOutput",
]
