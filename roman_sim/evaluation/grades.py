"""The front end graded against truth: masks against the instance image, descriptors by object.

Segmentation, per frame. The objects a segmenter should find are the true instances whose
visible area lies in ROMAN's mask window [A/30^2, A/3^2], compared after ROMAN's erosion
(so the ``perfect`` segmenter scores IoU 1). A mask *belongs* to the instance holding at
least ``belong_frac`` of its pixels (to the background when the background does). Masks
and objects are matched one to one by IoU (Hungarian, scipy), a match needing ``iou_match``.

- precision: matched masks / graded masks (masks belonging to an instance outside the
  window are not graded); recall: matched objects / objects; mean IoU of the matches. The
  headline figures count what a mapper can use: objects and masks within its depth range
  (``max_depth_m``, the mapper's 7.5 m), by their median valid depth (none valid: beyond);
  the far bin is reported apart, and ``*_all`` over every depth;
- over-segmentation: objects with two or more masks belonging to them; under-segmentation:
  masks holding at least ``cover_frac`` of each of two or more objects, out of the touching
  pairs (counted objects next to each other in the image, at any depth: the sensor leaves no
  valid depth across an occlusion edge);
- spurious masks (belonging to the background); objects detected (some mask belongs to
  them) and matched per distance bin (median valid depth of the object; no valid depth:
  the last, open bin) and per area bin; graded and matched masks per distance bin (the
  mask's median valid depth), so every bin has its precision, recall and IoU.

Descriptors: each observed mask that belongs to an instance contributes (instance, family,
horizontal viewing angle, descriptor); cosines of pairs from different frames are binned
for the same instance (also against the viewing-angle difference: mean and spread), the
same family, and other families (same group / other group), each with the share of pairs at
or above ROMAN's semantic gate (``gate_cos``, 0.85: CLIP's cos_min), the overlap figure.
``sides`` repeats the gate figure per relation from one side (viewing directions within
``side_deg``) and, for the same instance, from opposite sides (at least 180 - ``side_deg``
apart); with the simulated encoder's looks (``FrontEndGrader.appearance``), ``appearance``
bins the pairs of two instances of one family seen from one side by their appearance
difference, 1 - the encoder's appearance kernel (``appearance_edges``).
Observations beyond ``max_observations`` are reservoir-sampled with a seeded generator.
``FrontEndGrader`` (``frontend_grader``) computes them, the only reader of truth in front-end
grading; the results here are records (``roman_sim.core.records``: ``FrontEndGrades`` is the
``frontend`` section of ``metrics.json`` and ``maps/frontend.json``, its segmentation written with
the derived rates, ``SegmentationRecord``) and ``plot_frontend_grades`` draws them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from roman_sim.core.records import INLINE, via
from roman_sim.mapping.mask_filter import MaskFilterConfig

CLASSES = ("same_instance", "same_family", "same_group", "other_group")


class GradeConfig(MaskFilterConfig):
    """How masks are matched to objects and how distributions are binned."""

    iou_match: float = Field(0.5, gt=0, le=1)
    belong_frac: float = Field(0.5, gt=0, le=1)
    cover_frac: float = Field(0.3, gt=0, le=1)
    max_depth_m: float = Field(7.5, gt=0, le=100, description="the mapper's depth range: the headline figures")
    distance_edges_m: list[float] = Field(default_factory=lambda: [0.0, 2.5, 5.0, 7.5])
    area_edges_frac: list[float] = Field(default_factory=lambda: [0.0, 0.0025, 0.005, 0.01, 0.02, 0.05, 1.0])
    cos_bins: int = Field(100, ge=10, le=1000)
    view_step_deg: float = Field(15.0, gt=0, le=180)
    max_observations: int = Field(3000, ge=10, le=20000)
    gate_cos: float = Field(0.85, ge=-1, le=1, description="semantic gate whose pass share is reported")
    side_deg: float = Field(45.0, gt=0, le=90, description="one side: viewing directions at most this far apart")
    appearance_edges: list[float] = Field(
        default_factory=lambda: [0.0, 0.02, 0.1, 0.2, 0.3, 0.5, 1.0], description="appearance-difference bins"
    )

    @model_validator(mode="after")
    def _edges(self) -> GradeConfig:
        e = self.distance_edges_m
        if not e or e[0] != 0.0 or any(b <= a for a, b in zip(e, e[1:])):
            raise ValueError("distance_edges_m must start at 0 and increase")
        if self.max_depth_m not in e:  # the depth range is a bin edge (set without re-validating)
            self.__dict__["distance_edges_m"] = sorted([*e, self.max_depth_m])
        return self


@dataclass(frozen=True)
class RangeFigures:
    """Objects, masks and rates of the distance bins within or beyond the depth range (None: no tables)."""

    objects: int | None
    masks: int | None
    precision: float | None
    recall: float | None
    mean_iou: float | None


@dataclass(frozen=True)
class DistanceBin:
    """One distance bin: objects, missed (no mask belongs), unmatched (no IoU match), masks and rates."""

    from_m: float
    to_m: float | None
    in_range: bool
    objects: int
    missed: int
    unmatched: int
    recall: float | None
    masks: int
    precision: float | None
    mean_iou: float | None


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
    max_depth_m: float = 7.5
    dist_graded_masks: list[int] = field(default_factory=list)
    dist_matched_masks: list[int] = field(default_factory=list)
    dist_iou_sum: list[float] = field(default_factory=list)

    @property
    def precision_all(self) -> float | None:
        """Matched masks / graded masks at every depth (None without graded masks)."""
        return self.matched / self.graded_masks if self.graded_masks else None

    @property
    def recall_all(self) -> float | None:
        """Matched objects / objects at every depth (None without objects)."""
        return self.matched / self.objects if self.objects else None

    @property
    def mean_iou_all(self) -> float | None:
        """Mean IoU of the matched pairs at every depth."""
        return self.iou_sum / self.matched if self.matched else None

    def _near(self) -> NDArray[np.bool_]:
        """Distance bins within ``max_depth_m`` (the last bin is open)."""
        upper = np.array([*self.distance_edges_m[1:], np.inf])
        return upper <= self.max_depth_m + 1e-9

    def _range(self, near: bool) -> RangeFigures:
        """Objects, masks, matches and the rates of the bins within (``near``) or beyond the depth range."""
        if not self.dist_graded_masks or not self.table_objects:
            return RangeFigures(None, None, None, None, None)
        sel = self._near() if near else ~self._near()
        obj = int(np.asarray(self.table_objects, np.int64).sum(axis=0)[sel].sum())
        hit = int(np.asarray(self.table_matched, np.int64).sum(axis=0)[sel].sum())
        masks = int(np.asarray(self.dist_graded_masks, np.int64)[sel].sum())
        mm = int(np.asarray(self.dist_matched_masks, np.int64)[sel].sum())
        iou = float(np.asarray(self.dist_iou_sum, np.float64)[sel].sum())
        return RangeFigures(
            obj, masks, mm / masks if masks else None, hit / obj if obj else None, iou / mm if mm else None
        )

    @property
    def precision(self) -> float | None:
        """Headline precision: matched / graded masks within the depth range."""
        return self._range(True).precision

    @property
    def recall(self) -> float | None:
        """Headline recall: matched / counted objects within the depth range."""
        return self._range(True).recall

    @property
    def mean_iou(self) -> float | None:
        """Headline mean IoU of the matches within the depth range."""
        return self._range(True).mean_iou

    def far(self) -> RangeFigures:
        """Objects, masks and rates beyond the depth range (reported apart)."""
        return self._range(False)

    def by_distance(self) -> list[DistanceBin]:
        """Per distance bin: objects, missed (no mask belongs), unmatched (no IoU match), masks and rates."""
        if not self.table_objects:
            return []
        obj, det, mat = (
            np.asarray(t, dtype=np.int64).sum(axis=0)
            for t in (self.table_objects, self.table_detected, self.table_matched)
        )
        edges = [*self.distance_edges_m, None]
        n = len(obj)
        masks = self.dist_graded_masks or [0] * n
        mm = self.dist_matched_masks or [0] * n
        iou = self.dist_iou_sum or [0.0] * n
        near = self._near()
        return [
            DistanceBin(
                from_m=edges[i],  # type: ignore[arg-type]  # the lower edges are numbers
                to_m=edges[i + 1],
                in_range=bool(near[i]),
                objects=int(obj[i]),
                missed=int(obj[i] - det[i]),
                unmatched=int(obj[i] - mat[i]),
                recall=float(mat[i] / obj[i]) if obj[i] else None,
                masks=int(masks[i]),
                precision=float(mm[i] / masks[i]) if masks[i] else None,
                mean_iou=float(iou[i] / mm[i]) if mm[i] else None,
            )
            for i in range(n)
        ]


@dataclass(frozen=True)
class SegmentationRecord:
    """The segmentation grades as written: the counts and tables, then the derived rates (headline
    within the depth range, ``*_all`` at every depth), which are recomputed, not read back."""

    counts: SegmentationGrades = field(metadata=INLINE)
    precision: float | None = None
    recall: float | None = None
    mean_iou: float | None = None
    precision_all: float | None = None
    recall_all: float | None = None
    mean_iou_all: float | None = None
    far: RangeFigures | None = None
    by_distance: list[DistanceBin] = field(default_factory=list)

    @classmethod
    def of(cls, s: SegmentationGrades) -> SegmentationRecord:
        """The record of ``s`` with its rates."""
        return cls(
            s,
            s.precision,
            s.recall,
            s.mean_iou,
            s.precision_all,
            s.recall_all,
            s.mean_iou_all,
            s.far(),
            s.by_distance(),
        )


#: How a ``SegmentationGrades`` field is written (with its rates) and read (the counts alone).
SEGMENTATION_JSON = via(SegmentationRecord, SegmentationRecord.of, lambda r: r.counts)


@dataclass
class CosineStats:
    """Cosines of one class of descriptor pairs: summary and histogram on [-1, 1]."""

    pairs: int
    mean: float | None
    std: float | None
    p05: float | None
    p95: float | None
    hist: list[int]
    above_gate: int = 0

    @classmethod
    def of(cls, c: NDArray[np.float64], bins: int, gate: float = 0.85) -> CosineStats:
        """Statistics of the cosines ``c`` (``above_gate``: how many are at least ``gate``)."""
        h = np.histogram(np.clip(c, -1, 1), bins=bins, range=(-1.0, 1.0))[0].tolist()
        if len(c) == 0:
            return cls(0, None, None, None, None, h)
        q05, q95 = (float(q) for q in np.quantile(c, [0.05, 0.95]))
        return cls(len(c), float(c.mean()), float(c.std()), q05, q95, h, int(np.sum(c >= gate)))

    @property
    def frac_above_gate(self) -> float | None:
        """Share of the pairs at or above the gate (None without pairs)."""
        return self.above_gate / self.pairs if self.pairs else None


@dataclass
class DescriptorGrades:
    """Cosine distributions per class and the same-instance cosine against view difference."""

    observations: int
    classes: dict[str, CosineStats]
    view_edges_deg: list[float]
    view_mean: list[float | None]
    view_pairs: list[int]
    view_std: list[float | None] = field(default_factory=list)
    dim: int | None = None
    gate_cos: float = 0.85
    sides: dict[str, CosineStats] = field(default_factory=dict)
    appearance_edges: list[float] = field(default_factory=list)
    appearance: list[CosineStats] = field(default_factory=list)

    def other_family_above_gate(self) -> tuple[int, int]:
        """(pairs at or above the gate, pairs) of other families (same group and other group together)."""
        cls = [self.classes[k] for k in ("same_group", "other_group") if k in self.classes]
        return sum(c.above_gate for c in cls), sum(c.pairs for c in cls)


@dataclass
class FrontEndGrades:
    """What one run's front end scored: segmentation, and descriptors when an encoder ran (the
    ``frontend`` section of ``metrics.json``; the segmentation written with its rates)."""

    segmenter: str
    encoder: str | None
    segmentation: SegmentationGrades = field(metadata=SEGMENTATION_JSON)
    descriptors: DescriptorGrades | None = None
