"""``FrontEndGrader``: grades a front end frame by frame against the frame's truth.

Definitions are in ``roman_sim.evaluation.grades``. ``add(frame, masks, observed)``
has the signature of the mapper's ``on_frame`` hook, so grading runs during mapping for
whatever segmenter and encoder ran; nothing else in front-end grading reads truth.

Robots are mapped as separate tasks (possibly on other processes), so each robot is graded
on its own (``part()``: plain data, saved with the robot's checkpoint) and the run's grades
are ``FrontEndGrader.from_parts`` of the robots' parts in scenario order: the counts are
summed, and the kept observations are pooled (each robot's reservoir sample weighted by
how many it saw) and subsampled to ``max_observations`` with the run's seed. The result
does not depend on the executor or on which robots were resumed.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from roman_sim.core.errors import EvaluationError
from roman_sim.core.records import dumps_record, loads_record
from roman_sim.core.seeding import child_rng
from roman_sim.core.sensors import Frame, backproject
from roman_sim.evaluation.grades import (
    CLASSES,
    CosineStats,
    DescriptorGrades,
    FrontEndGrades,
    GradeConfig,
    SegmentationGrades,
    SegmentationRecord,
)
from roman_sim.frontend.frame_objects import FrameObjects, frame_objects
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.mask_filter import eroded_labels, masks_from_labels_reference


@dataclass
class _Obs:
    """One graded observation: instance, family, viewing angle (rad), frame key, descriptor."""

    oid: int
    family: str
    yaw: float
    frame: tuple[str, int]
    desc: NDArray[np.float32]


@dataclass
class GraderPart:
    """One robot's accumulated grades: segmentation counts, kept observations, observations seen."""

    seg: SegmentationGrades
    obs: list[_Obs]
    seen: int

    def arrays(self) -> dict[str, np.ndarray]:
        """The part as arrays (``roman_sim.core.atomic.write_npz``); inverse ``from_arrays``."""
        dim = len(self.obs[0].desc) if self.obs else 0
        seg = dumps_record(SegmentationRecord.of(self.seg))
        return {
            "seg": np.frombuffer(seg.encode(), dtype=np.uint8),
            "seen": np.array([self.seen], dtype=np.int64),
            "oid": np.array([o.oid for o in self.obs], dtype=np.int64),
            "family": np.array([o.family for o in self.obs], dtype=str),
            "yaw": np.array([o.yaw for o in self.obs], dtype=np.float64),
            "frame_robot": np.array([o.frame[0] for o in self.obs], dtype=str),
            "frame_index": np.array([o.frame[1] for o in self.obs], dtype=np.int64),
            "desc": np.stack([o.desc for o in self.obs]).astype(np.float32)
            if self.obs
            else np.zeros((0, dim), np.float32),
        }

    @classmethod
    def from_arrays(cls, d: Mapping[str, np.ndarray], source: str = "front-end grades part") -> GraderPart:
        """Inverse of ``arrays`` (RecordError names ``source`` when its segmentation counts are damaged)."""
        text = bytes(np.asarray(d["seg"], dtype=np.uint8))
        seg = loads_record(text, SegmentationRecord, f"{source}: seg").counts
        obs = [
            _Obs(int(o), str(f), float(y), (str(r), int(i)), np.asarray(v, dtype=np.float32))
            for o, f, y, r, i, v in zip(d["oid"], d["family"], d["yaw"], d["frame_robot"], d["frame_index"], d["desc"])
        ]
        return cls(seg, obs, int(np.asarray(d["seen"])[0]))


_COUNTS = (
    "frames",
    "masks",
    "graded_masks",
    "matched",
    "iou_sum",
    "objects",
    "spurious",
    "over_segmented",
    "under_segmented",
    "touching_pairs",
)
_TABLES = ("table_objects", "table_detected", "table_matched", "table_over", "dist_graded_masks", "dist_matched_masks")


class FrontEndGrader:
    """Accumulates grades frame by frame; ``add`` has the mapper's ``on_frame`` signature.

    Args:
        families: object id -> family (world truth).
        group_of: family -> group (e.g. ``SemanticConfig.group_of``); each family its own group when None.
        cfg: matching and binning.
        seed: seeds the reservoir sampling of observations.
    """

    def __init__(
        self,
        families: Mapping[int, str],
        group_of: Callable[[str], str] | None = None,
        cfg: GradeConfig | None = None,
        seed: int = 0,
        stream: str | None = None,
    ) -> None:
        self.cfg = cfg or GradeConfig()
        self.families = dict(families)
        self.group_of = group_of or (lambda f: f)
        n_a, n_d = len(self.cfg.area_edges_frac) - 1, len(self.cfg.distance_edges_m)

        def zeros() -> list[list[int]]:
            return [[0] * n_d for _ in range(n_a)]

        self.seg = SegmentationGrades(
            distance_edges_m=list(self.cfg.distance_edges_m),
            area_edges_frac=list(self.cfg.area_edges_frac),
            table_objects=zeros(),
            table_detected=zeros(),
            table_matched=zeros(),
            table_over=zeros(),
            max_depth_m=self.cfg.max_depth_m,
            dist_graded_masks=[0] * n_d,
            dist_matched_masks=[0] * n_d,
            dist_iou_sum=[0.0] * n_d,
        )
        self._obs: list[_Obs] = []
        self._seen = 0
        self._seed = seed
        #: (object id, object id) -> appearance kernel of the two instances (the simulated
        #: encoder's looks); None: no appearance table in the grades.
        self.appearance: Callable[[int, int], float] | None = None
        self._rng = child_rng(seed, "frontend_grades", *([] if stream is None else [stream]))

    def part(self) -> GraderPart:
        """This grader's counts and kept observations as plain data (one robot's share)."""
        return GraderPart(self.seg, list(self._obs), self._seen)

    @classmethod
    def from_parts(
        cls,
        parts: list[GraderPart],
        group_of: Callable[[str], str] | None = None,
        cfg: GradeConfig | None = None,
        seed: int = 0,
    ) -> FrontEndGrader:
        """A grader holding the sum of ``parts`` (in the given order; see the module docstring).

        Without ``cfg``, the parts' own depth range and bins are kept.
        """
        if cfg is None and parts:
            first = parts[0].seg
            cfg = GradeConfig(
                max_depth_m=first.max_depth_m,
                distance_edges_m=list(first.distance_edges_m),
                area_edges_frac=list(first.area_edges_frac),
            )
        out = cls({}, group_of, cfg, seed)
        s = out.seg
        for p in parts:
            for name in _COUNTS:
                setattr(s, name, getattr(s, name) + getattr(p.seg, name))
            for name in _TABLES:
                mine, theirs = getattr(s, name), getattr(p.seg, name)
                if len(theirs):
                    setattr(s, name, (np.asarray(mine, np.int64) + np.asarray(theirs, np.int64)).tolist())
            if len(p.seg.dist_iou_sum):
                s.dist_iou_sum = (np.asarray(s.dist_iou_sum) + np.asarray(p.seg.dist_iou_sum)).tolist()
        obs = [o for p in parts for o in p.obs]
        weight = np.array([p.seen / len(p.obs) for p in parts for _ in p.obs], dtype=np.float64)
        out._seen = sum(p.seen for p in parts)
        cap = out.cfg.max_observations
        if len(obs) > cap:
            rng = child_rng(seed, "frontend_grades", "pooled")
            keep = np.sort(rng.choice(len(obs), size=cap, replace=False, p=weight / weight.sum()))
            obs = [obs[int(k)] for k in keep]
        out._obs = obs
        return out

    def add(self, frame: Frame, masks: list[Mask], observed: list[tuple[int, NDArray[np.float32] | None]]) -> None:
        """Grade one frame's masks and keep its observed descriptors."""
        if frame.truth is None:
            raise EvaluationError(f"front-end grades: frame {frame.index} of robot {frame.robot} has no ground truth")
        ids = np.asarray(frame.truth.object_ids)
        owner = self._grade_masks(frame, ids, masks)
        for k, desc in observed:
            if desc is not None and owner[k] >= 0:
                self._keep(frame, masks[k], int(owner[k]), desc)

    def _bin(self, d: NDArray[np.float32]) -> int:
        """Distance bin of the median of the valid depths ``d`` (none valid: the last, open bin)."""
        d = d[d > 0]
        return self._dist_bin(float(np.median(d)) if len(d) else np.inf)

    def _dist_bin(self, dist: float) -> int:
        """Distance bin of ``dist`` metres (inf: the last, open bin)."""
        di = int(np.searchsorted(self.cfg.distance_edges_m, dist, side="right")) - 1
        return min(max(di, 0), len(self.cfg.distance_edges_m) - 1)

    def _match(
        self, iou: NDArray[np.float64], mask_bin: NDArray[np.int64], n_belong: NDArray[np.int64]
    ) -> NDArray[np.bool_]:
        """One-to-one matching of masks to objects by IoU (Hungarian); counts the matches, their IoU
        and the over-segmented objects; returns which objects were matched."""
        c, s = self.cfg, self.seg
        matched = np.zeros(iou.shape[1], dtype=bool)
        if iou.size:
            rows, cols = linear_sum_assignment(-iou)
            ok = iou[rows, cols] >= c.iou_match
            matched[cols[ok]] = True
            s.matched += int(ok.sum())
            s.iou_sum += float(iou[rows, cols][ok].sum())
            for i, v in zip(rows[ok].tolist(), iou[rows, cols][ok].tolist()):
                s.dist_matched_masks[mask_bin[i]] += 1
                s.dist_iou_sum[mask_bin[i]] += float(v)
        s.over_segmented += int((n_belong >= 2).sum())
        return matched

    def _grade_masks(self, frame: Frame, ids: NDArray[np.int32], masks: list[Mask]) -> NDArray[np.int64]:
        """Update the segmentation counts; return each mask's owner id (-1 background or mixed).

        The true masks are eroded all at once (``eroded_labels``) and every mask's overlaps with
        the objects and with their eroded masks are two ``np.bincount`` of the labels under it:
        the same counts as ``_grade_masks_reference``, which scans one object at a time.
        """
        if any(np.asarray(m.pixels).dtype != np.bool_ for m in masks):
            return self._grade_masks_reference(frame, ids, masks)
        c, s = self.cfg, self.seg
        depth = np.asarray(frame.depth)
        table = frame_objects(ids, depth)  # the segmenter's, when it read this frame's truth
        lab, counts = table.labels, table.counts  # label k = id k - 1 (0: background)
        n_lab = len(counts)
        lo, hi = c.area_range(ids.shape)
        eroded = eroded_labels(lab, c.erosion_radius(ids.shape[1]))
        e_area = np.bincount(eroded.ravel(), minlength=n_lab)
        counted = (counts >= lo) & (counts <= hi) & (e_area > 0)
        counted[0] = False
        labels = np.flatnonzero(counted)  # the counted objects' labels, in id order
        objs = (labels - 1).tolist()
        s.frames += 1
        s.masks += len(masks)
        s.objects += len(objs)
        col = {o: j for j, o in enumerate(objs)}
        owner = np.full(len(masks), -1, dtype=np.int64)
        mask_bin = np.zeros(len(masks), dtype=np.int64)
        iou = np.zeros((len(masks), len(objs)))
        n_belong = np.zeros(len(objs), dtype=np.int64)
        for i, m in enumerate(masks):
            r0, r1, c0, c1 = m.bbox  # type: ignore[misc]
            pix = m.pixels[r0:r1, c0:c1]
            under = lab[r0:r1, c0:c1][pix]
            n_pix = len(under)
            mask_bin[i] = self._bin(depth[r0:r1, c0:c1][pix])
            if n_pix:
                n = np.bincount(under, minlength=n_lab)
                top = int(np.argmax(n))  # the first largest count: np.unique's order
                if n[top] >= c.belong_frac * n_pix:
                    owner[i] = top - 1
                if owner[i] < 0 and top == 0:
                    s.spurious += 1
                covered = n[labels] >= c.cover_frac * counts[labels]
                covered &= n[labels] > 0
                s.under_segmented += int(np.count_nonzero(covered) >= 2)
                inter = np.bincount(eroded[r0:r1, c0:c1][pix], minlength=n_lab)[labels]
                hit = np.flatnonzero(inter)
                iou[i, hit] = inter[hit] / (n_pix + e_area[labels[hit]] - inter[hit])
            if owner[i] in col or owner[i] < 0:
                s.graded_masks += 1
                s.dist_graded_masks[mask_bin[i]] += 1
            if owner[i] in col:
                n_belong[col[owner[i]]] += 1
        matched = self._match(iou, mask_bin, n_belong)
        self._tables(table, labels, n_belong, matched)
        return owner

    def _tables(
        self, table: FrameObjects, labels: NDArray[np.int64], n_belong: NDArray[np.int64], matched: NDArray[np.bool_]
    ) -> None:
        """The area x distance tables and the touching pairs of the counted objects (labels ``labels``)."""
        s = self.seg
        edges = self.cfg.area_edges_frac
        area_bin = np.searchsorted(edges, table.counts[labels] / table.ids.size, side="right") - 1
        np.minimum(area_bin, len(edges) - 2, out=area_bin)
        for j, k in enumerate(labels.tolist()):
            di = self._dist_bin(table.depth_of(k - 1))  # the median of the object's valid depths (inf: none)
            ai = int(area_bin[j])
            s.table_objects[ai][di] += 1
            s.table_detected[ai][di] += int(n_belong[j] >= 1)
            s.table_matched[ai][di] += int(matched[j])
            s.table_over[ai][di] += int(n_belong[j] >= 2)
        counted = set((labels - 1).tolist())
        s.touching_pairs += sum(1 for a, b in table.neighbour_pairs(0) if a in counted and b in counted)

    def _objects_reference(self, ids: NDArray[np.int32]) -> tuple[list[int], list[Mask], NDArray[np.int64]]:
        """Counted object ids, their eroded true masks, and raw pixel counts per id (index id + 1)."""
        counts = np.bincount(ids.ravel() + 1)
        lab = np.where(ids >= 0, ids + 1, 0).astype(np.int32)
        lo, hi = self.cfg.area_range(ids.shape)
        eroded, kept = [], []
        for m in masks_from_labels_reference(lab, self.cfg):
            oid = int(ids[m.pixels][0])
            if lo <= counts[oid + 1] <= hi:
                kept.append(oid)
                eroded.append(m)
        return kept, eroded, counts

    def _grade_masks_reference(self, frame: Frame, ids: NDArray[np.int32], masks: list[Mask]) -> NDArray[np.int64]:
        """``_grade_masks`` with one eroded true mask per object and per-object image scans."""
        c, s = self.cfg, self.seg
        objs, eroded, counts = self._objects_reference(ids)
        depth = np.asarray(frame.depth)
        s.frames += 1
        s.masks += len(masks)
        s.objects += len(objs)
        col = {o: j for j, o in enumerate(objs)}
        owner = np.full(len(masks), -1, dtype=np.int64)
        mask_bin = np.zeros(len(masks), dtype=np.int64)
        iou = np.zeros((len(masks), len(objs)))
        n_belong = np.zeros(len(objs), dtype=np.int64)
        for i, m in enumerate(masks):
            r0, r1, c0, c1 = m.bbox  # type: ignore[misc]
            pix = m.pixels[r0:r1, c0:c1]
            under = ids[r0:r1, c0:c1][pix]
            mask_bin[i] = self._bin(depth[r0:r1, c0:c1][pix])
            u, n = np.unique(under, return_counts=True)
            top = int(np.argmax(n)) if len(n) else -1
            if top >= 0 and n[top] >= c.belong_frac * len(under):
                owner[i] = int(u[top])
            if owner[i] < 0 and top >= 0 and u[top] < 0:
                s.spurious += 1
            if owner[i] in col or owner[i] < 0:
                s.graded_masks += 1
                s.dist_graded_masks[mask_bin[i]] += 1
            if owner[i] in col:
                n_belong[col[owner[i]]] += 1
            covered = [o for o, k in zip(u.tolist(), n.tolist()) if o in col and k >= c.cover_frac * counts[o + 1]]
            s.under_segmented += int(len(covered) >= 2)
            for j, e in enumerate(eroded):
                inter = int(np.count_nonzero(e.pixels[r0:r1, c0:c1] & pix))
                if inter:
                    iou[i, j] = inter / (m.area + e.area - inter)
        matched = self._match(iou, mask_bin, n_belong)
        self._tables_reference(depth, ids, objs, counts, n_belong, matched)
        return owner

    def _tables_reference(
        self,
        depth: NDArray[np.float32],
        ids: NDArray[np.int32],
        objs: list[int],
        counts: NDArray[np.int64],
        n_belong: NDArray[np.int64],
        matched: NDArray[np.bool_],
    ) -> None:
        from roman_sim.frontend.mask_noise import neighbour_pairs

        A = ids.size
        s = self.seg
        for j, o in enumerate(objs):
            di = self._bin(depth[ids == o])
            ai = min(
                int(np.searchsorted(self.cfg.area_edges_frac, counts[o + 1] / A, side="right")) - 1,
                len(self.cfg.area_edges_frac) - 2,
            )
            s.table_objects[ai][di] += 1
            s.table_detected[ai][di] += int(n_belong[j] >= 1)
            s.table_matched[ai][di] += int(matched[j])
            s.table_over[ai][di] += int(n_belong[j] >= 2)
        counted = set(objs)
        s.touching_pairs += sum(1 for a, b in neighbour_pairs(ids, 0) if a in counted and b in counted)

    def _keep(self, frame: Frame, m: Mask, oid: int, desc: NDArray[np.float32]) -> None:
        assert frame.truth is not None
        T_world_cam = np.asarray(frame.truth.T_world_body) @ np.asarray(frame.T_body_cam)
        pts = backproject(frame.depth, frame.intrinsics, m.pixels)
        if len(pts) == 0:
            return
        centre = T_world_cam[:3, :3] @ pts.mean(axis=0)
        obs = _Obs(
            oid,
            self.families.get(oid, "unknown"),
            float(np.arctan2(centre[1], centre[0])),
            (frame.robot, int(frame.index)),
            np.asarray(desc, dtype=np.float32),
        )
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
        classes = {
            name: CosineStats.of(cos[sel], c.cos_bins, c.gate_cos)
            for name, sel in zip(CLASSES, (same_i, same_f, same_g, other))
        }
        dview = np.degrees(np.abs(np.angle(np.exp(1j * (yaw[i] - yaw[j])))))[same_i]
        edges = np.arange(0.0, 180.0 + c.view_step_deg / 2, c.view_step_deg)
        edges[-1] = 180.0
        b = np.clip(np.searchsorted(edges, dview, side="right") - 1, 0, len(edges) - 2)
        cs = cos[same_i]
        means = [float(cs[b == k].mean()) if np.any(b == k) else None for k in range(len(edges) - 1)]
        stds = [float(cs[b == k].std()) if np.any(b == k) else None for k in range(len(edges) - 1)]
        pairs = [int(np.sum(b == k)) for k in range(len(edges) - 1)]
        dall = np.degrees(np.abs(np.angle(np.exp(1j * (yaw[i] - yaw[j])))))
        one_side = dall <= c.side_deg
        sides = {
            name: CosineStats.of(cos[sel], c.cos_bins, c.gate_cos)
            for name, sel in (
                ("same_instance_same_side", same_i & one_side),
                ("same_instance_opposite", same_i & (dall >= 180.0 - c.side_deg)),
                ("same_family_same_side", same_f & one_side),
                ("other_family_same_side", (same_g | other) & one_side),
            )
        }
        appearance: list[CosineStats] = []
        if self.appearance is not None:
            sel = np.flatnonzero(same_f & one_side)
            # the kernel of each distinct object pair once (many observation pairs share one)
            objs, back = np.unique(np.stack([oid[i[sel]], oid[j[sel]]], 1), axis=0, return_inverse=True)
            kern = np.array([self.appearance(int(a), int(b)) for a, b in objs], dtype=np.float64)
            diff = 1.0 - kern[np.asarray(back).reshape(-1)]
            e = np.asarray(c.appearance_edges)
            b = np.clip(np.searchsorted(e, diff, side="right") - 1, 0, len(e) - 2) if len(sel) else sel
            appearance = [CosineStats.of(cos[sel][b == k], c.cos_bins, c.gate_cos) for k in range(len(e) - 1)]
        return DescriptorGrades(
            len(self._obs),
            classes,
            edges.tolist(),
            means,
            pairs,
            stds,
            int(D.shape[1]),
            c.gate_cos,
            sides,
            list(c.appearance_edges) if appearance else [],
            appearance,
        )

    def result(self, segmenter: str, encoder: str | None) -> FrontEndGrades:
        """The grades so far, labelled with the components' names."""
        return FrontEndGrades(segmenter, encoder, self.seg, self.descriptor_grades())
