"""The front end graded against truth: masks against the instance image, descriptors by object.

Segmentation, per frame. The objects a segmenter should find are the true instances whose
visible area lies in ROMAN's mask window [A/30^2, A/3^2], compared after ROMAN's erosion
(so the ``perfect`` segmenter scores IoU 1). A mask *belongs* to the instance holding at
least ``belong_frac`` of its pixels (to the background when the background does). Masks
and objects are matched one to one by IoU (Hungarian, scipy), a match needing ``iou_match``.

- precision: matched masks / graded masks (masks belonging to an instance outside the
  window are not graded); recall: matched objects / objects; mean IoU of the matches;
- over-segmentation: objects with two or more masks belonging to them; under-segmentation:
  masks holding at least ``cover_frac`` of each of two or more objects;
- spurious masks (belonging to the background); objects detected (some mask belongs to
  them) and matched per distance bin (median valid depth of the object; no valid depth:
  the last, open bin) and per area bin.

Descriptors: each observed mask that belongs to an instance contributes (instance, family,
horizontal viewing angle, descriptor); cosines of pairs from different frames are binned
for the same instance (also against the viewing-angle difference), the same family, and
other families (same group / other group). Observations beyond ``max_observations`` are
reservoir-sampled with a seeded generator. ``FrontEndGrader`` (``frontend_grader``) computes
them, the only reader of truth in front-end grading; the results here are JSON-ready
(``to_json`` / ``from_json``) and ``plot_frontend_grades`` draws them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.core.errors import EvaluationError
from roman_sim.core.jsontypes import JSONLike
from roman_sim.mapping.mask_filter import MaskFilterConfig

CLASSES = ("same_instance", "same_family", "same_group", "other_group")


class GradeConfig(MaskFilterConfig):
    """How masks are matched to objects and how distributions are binned."""

    iou_match: float = Field(0.5, gt=0, le=1)
    belong_frac: float = Field(0.5, gt=0, le=1)
    cover_frac: float = Field(0.3, gt=0, le=1)
    touch_depth_m: float = Field(
        0.3,
        ge=0,
        description="objects touching in the image within this depth step "
        "are a touching pair (chances for under-segmentation)",
    )
    distance_edges_m: list[float] = Field(default_factory=lambda: [0.0, 2.5, 5.0, 7.5])
    area_edges_frac: list[float] = Field(default_factory=lambda: [0.0, 0.0025, 0.005, 0.01, 0.02, 0.05, 1.0])
    cos_bins: int = Field(100, ge=10, le=1000)
    view_step_deg: float = Field(15.0, gt=0, le=180)
    max_observations: int = Field(3000, ge=10, le=20000)


@dataclass
class SegmentationGrades:
    """Accumulated segmentation counts; rates are properties. Tables are indexed by area bin, then distance bin."""

    frames: int = 0
    masks: int = 0
    graded_masks: int = 0
    matched: int = 0
    iou_sum: float = 0.0
    objects: int = 0
    spurious: int = 0
    over_segmented: int = 0
    under_segmented: int = 0
    touching_pairs: int = 0
    distance_edges_m: list[float] = field(default_factory=list)
    area_edges_frac: list[float] = field(default_factory=list)
    table_objects: list[list[int]] = field(default_factory=list)
    table_detected: list[list[int]] = field(default_factory=list)
    table_matched: list[list[int]] = field(default_factory=list)
    table_over: list[list[int]] = field(default_factory=list)

    @property
    def precision(self) -> float | None:
        """Matched masks / graded masks (None without graded masks)."""
        return self.matched / self.graded_masks if self.graded_masks else None

    @property
    def recall(self) -> float | None:
        """Matched objects / objects (None without objects)."""
        return self.matched / self.objects if self.objects else None

    @property
    def mean_iou(self) -> float | None:
        """Mean IoU of the matched pairs."""
        return self.iou_sum / self.matched if self.matched else None

    def by_distance(self) -> list[dict[str, Any]]:
        """Per distance bin: objects, missed (no mask belongs), unmatched (no IoU match)."""
        if not self.table_objects:
            return []
        obj, det, mat = (
            np.asarray(t, dtype=np.int64).sum(axis=0)
            for t in (self.table_objects, self.table_detected, self.table_matched)
        )
        edges = [*self.distance_edges_m, None]
        return [
            {
                "from_m": edges[i],
                "to_m": edges[i + 1],
                "objects": int(obj[i]),
                "missed": int(obj[i] - det[i]),
                "unmatched": int(obj[i] - mat[i]),
            }
            for i in range(len(obj))
        ]

    def to_json(self) -> dict[str, JSONLike]:
        """Counts, tables and the derived rates."""
        out = asdict(self)
        out.update(precision=self.precision, recall=self.recall, mean_iou=self.mean_iou, by_distance=self.by_distance())
        return out

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> SegmentationGrades:
        """Inverse of ``to_json`` (derived entries are ignored)."""
        names = set(cls.__dataclass_fields__)
        return cls(**{k: v for k, v in data.items() if k in names})


@dataclass
class CosineStats:
    """Cosines of one class of descriptor pairs: summary and histogram on [-1, 1]."""

    pairs: int
    mean: float | None
    std: float | None
    p05: float | None
    p95: float | None
    hist: list[int]

    @classmethod
    def of(cls, c: NDArray[np.float64], bins: int) -> CosineStats:
        """Statistics of the cosines ``c``."""
        h = np.histogram(np.clip(c, -1, 1), bins=bins, range=(-1.0, 1.0))[0].tolist()
        if len(c) == 0:
            return cls(0, None, None, None, None, h)
        return cls(len(c), float(c.mean()), float(c.std()), float(np.quantile(c, 0.05)), float(np.quantile(c, 0.95)), h)


@dataclass
class DescriptorGrades:
    """Cosine distributions per class and the same-instance cosine against view difference."""

    observations: int
    classes: dict[str, CosineStats]
    view_edges_deg: list[float]
    view_mean: list[float | None]
    view_pairs: list[int]

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> DescriptorGrades:
        """Inverse of ``to_json``."""
        d = dict(data)
        d["classes"] = {k: CosineStats(**v) for k, v in d["classes"].items()}
        return cls(**d)


@dataclass
class FrontEndGrades:
    """What one run's front end scored: segmentation, and descriptors when an encoder ran."""

    segmenter: str
    encoder: str | None
    segmentation: SegmentationGrades
    descriptors: DescriptorGrades | None

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict (the ``frontend`` section of metrics.json)."""
        return {
            "segmenter": self.segmenter,
            "encoder": self.encoder,
            "segmentation": self.segmentation.to_json(),
            "descriptors": None if self.descriptors is None else self.descriptors.to_json(),
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> FrontEndGrades:
        """Inverse of ``to_json``; ``EvaluationError`` when entries are missing."""
        try:
            desc = data.get("descriptors")
            return cls(
                str(data["segmenter"]),
                data.get("encoder"),
                SegmentationGrades.from_json(data["segmentation"]),
                None if desc is None else DescriptorGrades.from_json(desc),
            )
        except (KeyError, TypeError) as err:
            raise EvaluationError(f"front-end grades: malformed entry ({err})") from None
