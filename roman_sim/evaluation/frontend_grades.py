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
reservoir-sampled with a seeded generator. This module is the only reader of truth in
front-end grading; results are JSON-ready (``to_json`` / ``from_json``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field
from scipy.optimize import linear_sum_assignment

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import EvaluationError
from roman_sim.core.seeding import child_rng
from roman_sim.mapping.mask_filter import MaskFilterConfig, masks_from_labels
from roman_sim.mapping.segmenter import Mask
from roman_sim.sensors import Frame, backproject

CLASSES = ("same_instance", "same_family", "same_group", "other_group")


class GradeConfig(MaskFilterConfig):
    """How masks are matched to objects and how distributions are binned."""

    iou_match: float = Field(0.5, gt=0, le=1)
    belong_frac: float = Field(0.5, gt=0, le=1)
    cover_frac: float = Field(0.3, gt=0, le=1)
    touch_depth_m: float = Field(0.3, ge=0, description="objects touching in the image within this depth step "
                                 "are a touching pair (chances for under-segmentation)")
    distance_edges_m: list[float] = Field(default_factory=lambda: [0.0, 2.5, 5.0, 7.5])
    area_edges_frac: list[float] = Field(default_factory=lambda: [0.0, 0.0025, 0.005, 0.01, 0.02, 0.05, 1.0])
    cos_bins: int = Field(100, ge=10, le=1000)
    view_step_deg: float = Field(15.0, gt=0, le=180)
    max_observations: int = Field(3000, ge=10, le=20000)


@dataclass
class SegmentationGrades:
    """Accumulated segmentation counts; rates are properties. Tables are [area bin][distance bin]."""

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
        obj, det, mat = (np.asarray(t, dtype=np.int64).sum(axis=0) for t in
                         (self.table_objects, self.table_detected, self.table_matched))
        edges = [*self.distance_edges_m, None]
        return [{"from_m": edges[i], "to_m": edges[i + 1], "objects": int(obj[i]),
                 "missed": int(obj[i] - det[i]), "unmatched": int(obj[i] - mat[i])} for i in range(len(obj))]

    def to_json(self) -> dict[str, Any]:
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
        return cls(int(len(c)), float(c.mean()), float(c.std()), float(np.quantile(c, 0.05)),
                   float(np.quantile(c, 0.95)), h)


@dataclass
class DescriptorGrades:
    """Cosine distributions per class and the same-instance cosine against view difference."""

    observations: int
    classes: dict[str, CosineStats]
    view_edges_deg: list[float]
    view_mean: list[float | None]
    view_pairs: list[int]

    def to_json(self) -> dict[str, Any]:
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

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (the ``frontend`` section of metrics.json)."""
        return {"segmenter": self.segmenter, "encoder": self.encoder, "segmentation": self.segmentation.to_json(),
                "descriptors": None if self.descriptors is None else self.descriptors.to_json()}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> FrontEndGrades:
        """Inverse of ``to_json``; ``EvaluationError`` when entries are missing."""
        try:
            desc = data.get("descriptors")
            return cls(str(data["segmenter"]), data.get("encoder"), SegmentationGrades.from_json(data["segmentation"]),
                       None if desc is None else DescriptorGrades.from_json(desc))
        except (KeyError, TypeError) as err:
            raise EvaluationError(f"front-end grades: malformed entry ({err})") from None


@dataclass
class _Obs:
    """One graded observation: instance, family, viewing angle (rad), frame key, descriptor."""

    oid: int
    family: str
    yaw: float
    frame: tuple[str, int]
    desc: NDArray[np.float32]


class FrontEndGrader:
    """Accumulates grades frame by frame; ``add`` has the mapper's ``on_frame`` signature.

    Args:
        families: object id -> family (world truth).
        group_of: family -> group (e.g. ``SemanticConfig.group_of``); each family its own group when None.
        cfg: matching and binning.
        seed: seeds the reservoir sampling of observations.
    """

    def __init__(self, families: Mapping[int, str], group_of: Callable[[str], str] | None = None,
                 cfg: GradeConfig | None = None, seed: int = 0) -> None:
        self.cfg = cfg or GradeConfig()
        self.families = dict(families)
        self.group_of = group_of or (lambda f: f)
        n_a, n_d = len(self.cfg.area_edges_frac) - 1, len(self.cfg.distance_edges_m)
        zeros = lambda: [[0] * n_d for _ in range(n_a)]  # noqa: E731
        self.seg = SegmentationGrades(distance_edges_m=list(self.cfg.distance_edges_m),
                                      area_edges_frac=list(self.cfg.area_edges_frac), table_objects=zeros(),
                                      table_detected=zeros(), table_matched=zeros(), table_over=zeros())
        self._obs: list[_Obs] = []
        self._seen = 0
        self._rng = child_rng(seed, "frontend_grades")

    def add(self, frame: Frame, masks: list[Mask], observed: list[tuple[int, NDArray[np.float32] | None]]) -> None:
        """Grade one frame's masks and keep its observed descriptors."""
        if frame.truth is None:
            raise EvaluationError(f"front-end grades: frame {frame.index} of robot {frame.robot} has no ground truth")
        ids = np.asarray(frame.truth.object_ids)
        owner = self._grade_masks(frame, ids, masks)
        for k, desc in observed:
            if desc is not None and owner[k] >= 0:
                self._keep(frame, masks[k], int(owner[k]), desc)

    def _objects(self, ids: NDArray[np.int32]) -> tuple[list[int], list[Mask], NDArray[np.int64]]:
        """Counted object ids, their eroded true masks, and raw pixel counts per id (index id + 1)."""
        counts = np.bincount(ids.ravel() + 1)
        lab = np.where(ids >= 0, ids + 1, 0).astype(np.int32)
        lo, hi = self.cfg.area_range(ids.shape)
        eroded, kept = [], []
        for m in masks_from_labels(lab, self.cfg):
            oid = int(ids[m.pixels][0])
            if lo <= counts[oid + 1] <= hi:
                kept.append(oid)
                eroded.append(m)
        return kept, eroded, counts

    def _grade_masks(self, frame: Frame, ids: NDArray[np.int32], masks: list[Mask]) -> NDArray[np.int64]:
        """Update the segmentation counts; return each mask's owner id (-1 background or mixed)."""
        c, s = self.cfg, self.seg
        objs, eroded, counts = self._objects(ids)
        s.frames += 1
        s.masks += len(masks)
        s.objects += len(objs)
        col = {o: j for j, o in enumerate(objs)}
        owner = np.full(len(masks), -1, dtype=np.int64)
        iou = np.zeros((len(masks), len(objs)))
        n_belong = np.zeros(len(objs), dtype=np.int64)
        for i, m in enumerate(masks):
            r0, r1, c0, c1 = m.bbox  # type: ignore[misc]
            pix = m.pixels[r0:r1, c0:c1]
            under = ids[r0:r1, c0:c1][pix]
            u, n = np.unique(under, return_counts=True)
            top = int(np.argmax(n)) if len(n) else -1
            if top >= 0 and n[top] >= c.belong_frac * len(under):
                owner[i] = int(u[top])
            if owner[i] < 0 and top >= 0 and u[top] < 0:
                s.spurious += 1
            if owner[i] in col or owner[i] < 0:
                s.graded_masks += 1
            if owner[i] in col:
                n_belong[col[owner[i]]] += 1
            covered = [o for o, k in zip(u.tolist(), n.tolist()) if o in col and k >= c.cover_frac * counts[o + 1]]
            s.under_segmented += int(len(covered) >= 2)
            for j, e in enumerate(eroded):
                inter = int(np.count_nonzero(e.pixels[r0:r1, c0:c1] & pix))
                if inter:
                    iou[i, j] = inter / (m.area + e.area - inter)
        matched = np.zeros(len(objs), dtype=bool)
        if len(masks) and len(objs):
            rows, cols = linear_sum_assignment(-iou)
            ok = iou[rows, cols] >= c.iou_match
            matched[cols[ok]] = True
            s.matched += int(ok.sum())
            s.iou_sum += float(iou[rows, cols][ok].sum())
        s.over_segmented += int((n_belong >= 2).sum())
        self._tables(frame, ids, objs, counts, n_belong, matched)
        return owner

    def _tables(self, frame: Frame, ids: NDArray[np.int32], objs: list[int], counts: NDArray[np.int64],
                n_belong: NDArray[np.int64], matched: NDArray[np.bool_]) -> None:
        from roman_sim.mapping.mask_noise import adjacent_pairs

        depth = np.asarray(frame.depth)
        A = ids.size
        s = self.seg
        for j, o in enumerate(objs):
            d = depth[(ids == o) & (depth > 0)]
            dist = float(np.median(d)) if len(d) else np.inf
            di = int(np.searchsorted(self.cfg.distance_edges_m, dist, side="right")) - 1
            ai = min(int(np.searchsorted(self.cfg.area_edges_frac, counts[o + 1] / A, side="right")) - 1,
                     len(self.cfg.area_edges_frac) - 2)
            di = min(max(di, 0), len(self.cfg.distance_edges_m) - 1)
            s.table_objects[ai][di] += 1
            s.table_detected[ai][di] += int(n_belong[j] >= 1)
            s.table_matched[ai][di] += int(matched[j])
            s.table_over[ai][di] += int(n_belong[j] >= 2)
        counted = set(objs)
        s.touching_pairs += sum(1 for a, b in adjacent_pairs(ids, depth.astype(np.float32), self.cfg.touch_depth_m)
                                if a in counted and b in counted)

    def _keep(self, frame: Frame, m: Mask, oid: int, desc: NDArray[np.float32]) -> None:
        assert frame.truth is not None
        T_world_cam = np.asarray(frame.truth.T_world_body) @ np.asarray(frame.T_body_cam)
        pts = backproject(frame.depth, frame.intrinsics, m.pixels)
        if len(pts) == 0:
            return
        centre = T_world_cam[:3, :3] @ pts.mean(axis=0)
        obs = _Obs(oid, self.families.get(oid, "unknown"), float(np.arctan2(centre[1], centre[0])),
                   (frame.robot, int(frame.index)), np.asarray(desc, dtype=np.float32))
        self._seen += 1
        if len(self._obs) < self.cfg.max_observations:
            self._obs.append(obs)
        else:
            j = int(self._rng.integers(self._seen))
            if j < self.cfg.max_observations:
                self._obs[j] = obs

    def descriptor_grades(self) -> DescriptorGrades | None:
        """Cosine distributions of the kept observations (None when no descriptor was kept)."""
        if not self._obs:
            return None
        c = self.cfg
        D = np.stack([o.desc for o in self._obs]).astype(np.float64)
        C = D @ D.T
        oid = np.array([o.oid for o in self._obs])
        fam = np.array([o.family for o in self._obs])
        grp = np.array([self.group_of(f) for f in fam])
        yaw = np.array([o.yaw for o in self._obs])
        keys: dict[tuple[str, int], int] = {}
        fkey = np.array([keys.setdefault(o.frame, len(keys)) for o in self._obs])
        i, j = np.triu_indices(len(self._obs), k=1)
        diff_frame = fkey[i] != fkey[j]
        i, j = i[diff_frame], j[diff_frame]
        cos = C[i, j]
        same_i = oid[i] == oid[j]
        same_f = ~same_i & (fam[i] == fam[j])
        same_g = ~same_i & ~same_f & (grp[i] == grp[j])
        other = ~same_i & ~same_f & ~same_g
        classes = {name: CosineStats.of(cos[sel], c.cos_bins)
                   for name, sel in zip(CLASSES, (same_i, same_f, same_g, other))}
        dview = np.degrees(np.abs(np.angle(np.exp(1j * (yaw[i] - yaw[j])))))[same_i]
        edges = np.arange(0.0, 180.0 + c.view_step_deg / 2, c.view_step_deg)
        edges[-1] = 180.0
        b = np.clip(np.searchsorted(edges, dview, side="right") - 1, 0, len(edges) - 2)
        cs = cos[same_i]
        means = [float(cs[b == k].mean()) if np.any(b == k) else None for k in range(len(edges) - 1)]
        pairs = [int(np.sum(b == k)) for k in range(len(edges) - 1)]
        return DescriptorGrades(len(self._obs), classes, edges.tolist(), means, pairs)

    def result(self, segmenter: str, encoder: str | None) -> FrontEndGrades:
        """The grades so far, labelled with the components' names."""
        return FrontEndGrades(segmenter, encoder, self.seg, self.descriptor_grades())


def plot_frontend_grades(grades: FrontEndGrades, path: str | Path) -> Path:
    """Three panels: cosine histograms per class, cosine against view difference, objects by distance."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from roman_sim.evaluation.plots import save_png

    fig = Figure(figsize=(14, 4), dpi=100)
    FigureCanvasAgg(fig)
    ax1, ax2, ax3 = (fig.add_subplot(1, 3, k) for k in (1, 2, 3))
    d = grades.descriptors
    if d is not None:
        n = len(next(iter(d.classes.values())).hist)
        centres = np.linspace(-1, 1, n + 1)[:-1] + 1.0 / n
        for name, st in d.classes.items():
            if st.pairs:
                ax1.plot(centres, np.asarray(st.hist) / st.pairs, label=f"{name} ({st.pairs})")
        mids = 0.5 * (np.asarray(d.view_edges_deg[:-1]) + np.asarray(d.view_edges_deg[1:]))
        ax2.plot(mids, [np.nan if v is None else v for v in d.view_mean], "o-")
        ax1.legend(fontsize=7)
    ax1.set(xlabel="cosine", ylabel="share of pairs", title=f"descriptors: {grades.encoder or 'none'}")
    ax2.set(xlabel="view difference (deg)", ylabel="mean cosine, same instance", xlim=(0, 180))
    rows = grades.segmentation.by_distance()
    labels = [f"{r['from_m']:g}-{'' if r['to_m'] is None else format(r['to_m'], 'g')}" for r in rows]
    x = np.arange(len(rows))
    ax3.bar(x - 0.2, [r["objects"] for r in rows], 0.4, label="objects")
    ax3.bar(x + 0.2, [r["missed"] for r in rows], 0.4, label="missed")
    ax3.set_xticks(x, labels)
    s = grades.segmentation
    fmt = lambda v: "n/a" if v is None else f"{v:.2f}"  # noqa: E731
    ax3.set(xlabel="object distance (m)", ylabel="object views",
            title=f"{grades.segmenter}: P {fmt(s.precision)} R {fmt(s.recall)} IoU {fmt(s.mean_iou)}")
    ax3.legend(fontsize=7)
    return save_png(fig, path)
