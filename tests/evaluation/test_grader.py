"""Front-end grades on hand-built frames: every count and cosine is known in advance."""

import json

import numpy as np
import pytest

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import R_FLU_RDF, make_T
from roman_sim.core.records import RecordError, from_json, read_record, to_json, write_record
from roman_sim.core.sensors import Frame, FrameTruth, Intrinsics
from roman_sim.evaluation.grader import FrontEndGrader
from roman_sim.evaluation.grades import FrontEndGrades, GradeConfig, RangeFigures
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.mask_filter import MaskFilterConfig, masks_from_labels
from roman_sim.report.grades import frontend_report_lines, plot_frontend_grades

H, W = 120, 160
# Erosion is given at 640 px width: 12 px there is the 3 px radius these 160 px frames are built for.
CFG = GradeConfig(erosion_px=12)
INTR = Intrinsics(W, H, 80.0, 80.0, (W - 1) / 2, (H - 1) / 2)
T_BC = make_T(R_FLU_RDF, [0.0, 0.0, 0.5])


def frame(ids, depth, index=0, yaw=0.0, robot="a"):
    c, s = np.cos(yaw), np.sin(yaw)
    T_wb = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    return Frame(robot, index, index / 6, None, depth.astype(np.float32), T_wb, T_BC, INTR, FrameTruth(ids, T_wb))


def scene():
    """Three objects: 0 (big, 3 m), 1 (medium, 6 m), 2 (beyond range: no valid depth), terrain around."""
    ids = np.full((H, W), -1, np.int32)
    depth = np.full((H, W), 5.0, np.float32)
    ids[20:60, 10:50] = 0
    depth[20:60, 10:50] = 3.0
    ids[30:60, 80:110] = 1
    depth[30:60, 80:110] = 6.0
    ids[70:90, 120:150] = 2
    depth[70:90, 120:150] = 0.0
    return ids, depth


def truth_masks(ids):
    return masks_from_labels(np.where(ids >= 0, ids + 1, 0).astype(np.int32), MaskFilterConfig(erosion_px=12))


def box(r0, r1, c0, c1):
    m = np.zeros((H, W), bool)
    m[r0:r1, c0:c1] = True
    return Mask(m)


def test_perfect_masks_score_one():
    ids, depth = scene()
    g = FrontEndGrader({0: "rock", 1: "bush", 2: "rock"}, cfg=CFG)
    g.add(frame(ids, depth), truth_masks(ids), [])
    s = g.seg
    assert (s.objects, s.masks, s.matched, s.spurious, s.over_segmented, s.under_segmented) == (3, 3, 3, 0, 0, 0)
    assert s.precision == s.recall == 1.0 and s.mean_iou == pytest.approx(1.0)
    rows = s.by_distance()
    assert [r.objects for r in rows] == [0, 1, 1, 1]  # 3 m, 6 m, and no valid depth (open last bin)
    assert [r.missed for r in rows] == [0, 0, 0, 0]
    assert sum(map(sum, s.table_objects)) == 3


def test_errors_are_counted():
    ids, depth = scene()
    t = truth_masks(ids)
    split_a, split_b = box(23, 57, 13, 33), box(23, 57, 33, 47)  # object 0 in two parts: IoU 680/1156, 476/1156
    merged = Mask(ids >= 1)  # objects 1 and 2 in one mask (under-segmentation)
    sky = box(95, 115, 10, 40)  # terrain only: spurious
    g = FrontEndGrader({}, cfg=CFG)
    g.add(frame(ids, depth), [split_a, split_b, merged, sky], [])
    s = g.seg
    assert s.over_segmented == 1 and s.under_segmented == 1 and s.spurious == 1
    # Only the larger part of object 0 matches; the merged mask's IoU with object 1 is 576/1500.
    assert t[0].area == 34 * 34 and t[1].area == 24 * 24
    assert s.matched == 1 and s.mean_iou == pytest.approx(680 / 1156)
    assert s.graded_masks == 4 and s.precision_all == 0.25 and s.recall_all == pytest.approx(1 / 3)
    # Within the mapper's 7.5 m: objects 0 (3 m) and 1 (6 m); object 2 (no valid depth) is far.
    # Every mask lies within range (the merged one at the 6 m of its valid pixels, the sky at 5 m).
    assert s.recall == pytest.approx(1 / 2) and s.precision == 0.25 and s.mean_iou == pytest.approx(680 / 1156)
    assert s.far() == RangeFigures(objects=1, masks=0, precision=None, recall=0.0, mean_iou=None)
    rows = s.by_distance()
    assert [r.masks for r in rows] == [0, 2, 2, 0] and [r.in_range for r in rows] == [True] * 3 + [False]
    assert rows[1].precision == 0.5 and rows[1].recall == 1.0 and rows[2].recall == 0.0
    # The touching pair: objects 1 and 2 lie apart in the image, so none.
    assert s.touching_pairs == 0
    # No mask at all: every object missed, in its distance bin.
    g2 = FrontEndGrader({}, cfg=CFG)
    g2.add(frame(ids, depth), [], [])
    assert [r.missed for r in g2.seg.by_distance()] == [0, 1, 1, 1] and g2.seg.precision is None


def test_objects_outside_romans_window_are_not_graded():
    ids, depth = scene()
    ids[0:2, 0:2] = 7  # 4 pixels: below A / 30^2
    big = np.full((H, W), 9, np.int32)
    big[:, :20] = -1  # one object filling most of the image: above A / 3^2
    g = FrontEndGrader({}, cfg=CFG)
    g.add(frame(ids, depth), truth_masks(ids), [])
    assert g.seg.objects == 3
    g.add(frame(big, depth, 1), [Mask(big >= 0)], [])
    assert g.seg.objects == 3 and g.seg.masks == 4 and g.seg.graded_masks == 3


def test_descriptor_cosines_by_class_and_view():
    ids, depth = scene()
    fams = {0: "conifer", 1: "deciduous", 2: "boulder"}
    groups = {"conifer": "tree", "deciduous": "tree", "boulder": "rock"}
    g = FrontEndGrader(fams, groups.get, GradeConfig(view_step_deg=30.0, erosion_px=12))
    e = np.eye(4, dtype=np.float32)
    masks = truth_masks(ids)
    desc0 = [np.array([1, 0, 0, 0], np.float32), np.array([0.8, 0.6, 0, 0], np.float32)]
    for k, yaw in enumerate((0.0, np.pi / 2)):
        obs = [(0, desc0[k]), (1, e[2]), (2, e[3])]
        g.add(frame(ids, depth, k, yaw), masks, obs)
    d = g.descriptor_grades()
    assert d.observations == 4, "object 2 has no valid depth: no viewing direction, not kept"
    same = d.classes["same_instance"]
    assert same.pairs == 2 and same.mean == pytest.approx(0.9)  # object 0: 0.8; object 1: 1.0
    assert d.classes["same_group"].pairs == 2 and d.classes["same_group"].mean == pytest.approx(0.0)
    assert d.classes["other_group"].pairs == 0 and d.classes["same_family"].pairs == 0
    # Views turn with the robot by 90 deg: both same-instance pairs fall in the 90-120 bin.
    assert d.view_pairs[3] == 2 and d.view_mean[3] == pytest.approx(0.9) and d.view_mean[0] is None
    assert d.view_std[3] == pytest.approx(0.1) and d.dim == 4
    assert sum(same.hist) == 2
    # The overlap figure: pairs at or above the 0.85 gate (object 1's 1.0 passes, object 0's 0.8 does not).
    assert same.above_gate == 1 and same.frac_above_gate == 0.5
    assert d.other_family_above_gate() == (0, 2)
    lines = "\n".join(frontend_report_lines(g.result("perfect", "test")))
    assert "Other-family pairs passing the 0.85 semantic gate: 0.000 (0 of 2)." in lines
    assert "| within 7.5 m | 1.00 | 1.00 |" in lines and "| 7.5- (beyond range) | 2 |" in lines  # two frames


def test_reservoir_keeps_the_cap_and_is_seeded():
    ids, depth = scene()

    def run(seed):
        g = FrontEndGrader({}, cfg=GradeConfig(max_observations=10, erosion_px=12), seed=seed)
        for k in range(12):
            g.add(frame(ids, depth, k), truth_masks(ids), [(0, np.float32([1, k, 0])), (1, np.float32([0, 1, k]))])
        return g

    a, b = run(0), run(0)
    assert len(a._obs) == 10 and a._seen == 24
    assert [o.frame for o in a._obs] == [o.frame for o in b._obs]


def test_json_round_trip_plot_and_bad_input(tmp_path):
    ids, depth = scene()
    g = FrontEndGrader({0: "rock", 1: "rock"}, cfg=CFG)
    masks = truth_masks(ids)
    for k in range(2):
        g.add(frame(ids, depth, k), masks, [(0, np.float32([1, 0])), (1, np.float32([0.6, 0.8]))])
    res = g.result("perfect", "simulated")
    write_record(tmp_path / "frontend.json", res)
    back = read_record(tmp_path / "frontend.json", FrontEndGrades)
    assert to_json(back) == to_json(res) and back.segmentation == res.segmentation
    assert json.loads((tmp_path / "frontend.json").read_text())["segmentation"]["recall"] == 1.0  # rates written
    png = plot_frontend_grades(res, tmp_path / "plots" / "frontend.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert plot_frontend_grades(res, tmp_path / "again.png").read_bytes() == png.read_bytes()
    with pytest.raises(EvaluationError, match="no ground truth"):
        g.add(frame(ids, depth).public(), masks, [])
    with pytest.raises(RecordError, match=r"^grades: field encoder: missing$"):
        from_json(FrontEndGrades, {"segmenter": "x"}, "grades")
    damaged = json.loads((tmp_path / "frontend.json").read_text())
    damaged["segmentation"]["table_objects"] = "many"
    with pytest.raises(RecordError, match=r"^grades: field segmentation.table_objects: expected a list"):
        from_json(FrontEndGrades, damaged, "grades")
    assert FrontEndGrader({}).descriptor_grades() is None
