"""Plots are produced as real PNGs; a plot that would carry one point is not drawn."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import make_T, rot_z
from roman_sim.evaluation.metrics import compute_metrics, score_pair
from roman_sim.evaluation.pairs import pair_truth
from roman_sim.report.examples import draw_examples, pick_examples, plot_alignment
from roman_sim.report.maskview import overlay, plot_masks
from roman_sim.report.plots import plot_heading_recall, write_metric_plots

PNG = b"\x89PNG\r\n\x1a\n"


def _is_png(path) -> bool:
    data = path.read_bytes()
    return data.startswith(PNG) and len(data) > 2000


@pytest.fixture
def metrics(make_score):
    scores = []
    for method, shift in (("roman", 0), ("ransac", 3)):
        for i, h in enumerate([10.0, 70.0, 150.0, 170.0]):
            scores.append(make_score(str(i), True, 8 - shift - i, i < 2, method=method, heading=h, ambiguity=0.2 * i))
        scores.append(make_score("9", False, 6, False, method=method))
    return compute_metrics(scores)


def test_metric_plots_are_pngs_and_deterministic(metrics, tmp_path):
    paths, notes = write_metric_plots(metrics, tmp_path / "plots")
    # one ambiguity bin per pair here except the first: four bins with data; no association truth given
    assert [p.name for p in paths] == [
        "precision_recall.png",
        "precision_recall_heading.png",
        "recall_heading.png",
        "recall_heading_fine.png",
        "recall_ambiguity.png",
        "recall_operating_points.png",
    ]
    assert notes == ["plot association_heading.png not drawn: it needs two heading bins with true correspondences"]
    assert all(_is_png(p) for p in paths)
    again = plot_heading_recall(metrics, tmp_path / "again.png")
    assert again.read_bytes() == paths[2].read_bytes()


def test_plots_carrying_one_point_are_not_drawn(make_score, tmp_path):
    # every relevant pair in one heading bin and one ambiguity bin: bars and PR per bin would be one point
    scores = [make_score(str(i), True, 8 - i, i < 2, heading=10.0 + i, ambiguity=0.1) for i in range(4)]
    paths, notes = write_metric_plots(compute_metrics(scores), tmp_path)
    assert [p.name for p in paths] == ["precision_recall.png"]
    assert len(notes) == 6 and all("not drawn" in n for n in notes)
    (tmp_path / "recall_heading.png").write_bytes(b"stale")
    write_metric_plots(compute_metrics(scores), tmp_path)  # a plot no longer drawn leaves no stale file behind
    assert not (tmp_path / "recall_heading.png").exists()


def test_plots_with_undefined_metrics(make_score, tmp_path):
    paths, notes = write_metric_plots(compute_metrics([make_score("0", False, 3, False)]), tmp_path)
    assert paths == [] and len(notes) == 7
    assert write_metric_plots(compute_metrics([]), tmp_path / "empty")[0] == []


def test_alignment_drawings(make_submap, result_for, tmp_path):
    a = make_submap("a", 0, 0.0, 0.0, 0.0, object_ids=(1, 2, 3, 4), with_points=True)
    b = make_submap("b", 0, 2.0, 1.0, 30.0, object_ids=(1, 2, 3, 4), with_points=True)
    truth = pair_truth(a, b)
    good = result_for(truth.T_a_b_true, 4)
    wrong = result_for(truth.T_a_b_true @ make_T(rot_z(1.0), [3.0, 0, 0]), 3)
    wrong.associations[:] = [[0, 1], [1, 2], [2, 3]]
    scores = [score_pair(truth, good), score_pair(truth, wrong)]
    ok, bad = pick_examples(scores)
    assert ok is scores[0] and bad is scores[1]
    # wrong's result is looked up under the same key: give it its own method name
    scores[1] = score_pair(truth, type(wrong)(**{**wrong.__dict__, "method": "w"}))
    results = {(a.name, b.name, "m"): good, (a.name, b.name, "w"): wrong}
    paths = draw_examples(scores, {a.name: a, b.name: b}, results, tmp_path)
    assert [p.name for p in paths] == ["alignment_m.png", "alignment_w.png"]
    assert all(_is_png(p) for p in paths)
    with pytest.raises(EvaluationError, match="no estimate"):
        plot_alignment(a, b, result_for(None, 0), tmp_path / "x.png")
    bad_idx = result_for(np.eye(4), 2)
    bad_idx.associations[1] = [0, 9]
    with pytest.raises(EvaluationError, match="outside"):
        plot_alignment(a, b, bad_idx, tmp_path / "x.png")
    bad_idx.info["association_kind"] = "keyframe_features"  # visual: feature pairs, drawn without lines
    assert _is_png(plot_alignment(a, b, bad_idx, tmp_path / "visual.png"))
    with pytest.raises(EvaluationError, match="example pair"):
        draw_examples(scores, {}, results, tmp_path)


def test_map_view_renders_points_and_boxes(make_submap, tmp_path):
    from roman_sim.report.mapview import render_map, write_map_view

    pts = [make_submap("a", i, 4.0 * i, 0.0, 40.0 * i, object_ids=(1, 2, 3), with_points=True) for i in range(2)]
    boxes = [make_submap("b", 0, 2.0, 5.0, 180.0, object_ids=(4, 5))]
    img = render_map(pts + boxes, width=96, height=72)
    assert img.shape == (72, 96, 3) and img.dtype == np.uint8
    bg = img[0, 0]
    drawn = np.any(np.abs(img.astype(int) - bg) > 20, axis=2)
    assert drawn.sum() > 50  # ground slab and segments, not a blank frame
    assert len(np.unique(img[drawn], axis=0)) > 3  # several segment colours
    p = write_map_view(tmp_path / "map.png", [s.public() for s in boxes], frame="odom", width=64, height=48)
    assert _is_png(p) or p.read_bytes().startswith(PNG)
    with pytest.raises(EvaluationError, match="odom"):
        render_map([boxes[0].public()], frame="world")
    with pytest.raises(EvaluationError, match="valid"):
        render_map(boxes, frame="map")  # type: ignore[arg-type]
    with pytest.raises(EvaluationError, match="no segments"):
        render_map([make_submap("c", 0, 0.0, 0.0, object_ids=())])


def test_masks_over_an_image(tmp_path):
    rgb = np.full((48, 64, 3), 100, dtype=np.uint8)
    m1 = np.zeros((48, 64), bool)
    m1[10:20, 10:30] = True
    m2 = np.zeros((48, 64), bool)
    m2[30:40, 40:60] = True
    img = overlay(rgb, [m1, m2])
    assert img.shape == (48, 64, 3)
    np.testing.assert_allclose(img[0, 0], 100 / 255)  # untouched outside the masks
    assert np.all(img[10, 15] == 1.0) and not np.allclose(img[15, 20], 100 / 255)  # outline white, inside tinted
    assert not np.allclose(img[15, 20], img[35, 50])  # two masks, two colours
    assert _is_png(plot_masks(rgb, [m1, m2], tmp_path / "m.png", "two masks", ["7", None]))
    with pytest.raises(EvaluationError, match="shape"):
        overlay(rgb, [np.zeros((4, 4), bool)])
