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


def test_the_worst_false_positive_is_the_accepted_estimate_furthest_off(make_score):
    """Not the wrong estimate with the most associations (a near miss), but the accepted one with the largest
    error in tolerances; estimates below the acceptance threshold are not false positives."""
    from dataclasses import replace

    from roman_sim.report.examples import ExampleRule, example_title

    near = replace(make_score("1", True, 12, False), rot_err_deg=0.4, trans_err_m=1.25)  # 1.25 tolerances
    turned = replace(make_score("2", True, 5, False), rot_err_deg=30.0, trans_err_m=2.0)  # 30 / 5 = 6 tolerances
    far = replace(make_score("3", False, 4, False), rot_err_deg=3.0, trans_err_m=5.5)  # 5.5 tolerances
    below = replace(make_score("4", False, 3, False), rot_err_deg=170.0, trans_err_m=80.0)  # not accepted at k = 4
    good = make_score("5", True, 7, True)
    rule = ExampleRule(min_assoc=4, rot_tol_deg=5.0, trans_tol_m=1.0)
    scores = [near, turned, far, below, good]
    assert rule.false_positives(scores) == [turned, far, near]
    assert rule.error(turned) == 6.0 and rule.error(near) == 1.25
    assert pick_examples(scores, rule) == (good, turned)
    assert pick_examples(scores)[1] is below  # the default rule accepts any estimate
    assert pick_examples([below, good], rule) == (good, None)
    title = example_title("m", rule, 3, True)
    assert title == (
        "m: a correct alignment and the worst false positive\nworst: the largest error in tolerances "
        "(5 deg, 1 m) among the 3 wrong estimates with >= 4 associations"
    )
    assert example_title("m", rule, 0, False).endswith(
        "no wrong estimate has >= 4 associations; no correct relevant pair"
    )


def test_map_view_draws_each_segment_once_to_scale_where_the_truth_puts_it(make_submap, tmp_path):
    from dataclasses import replace

    from matplotlib.collections import EllipseCollection

    from roman_sim.core.geometry import transform_points
    from roman_sim.report.mapview import map_view_figure, write_map_view

    a0 = make_submap("a", 0, 4.0, 0.0, 40.0, object_ids=(1, 2, -1), with_points=True)
    # submap a/1 sees the same three segments again, from elsewhere: each is drawn once, from a/1
    a1 = replace(
        make_submap("a", 1, 10.0, 2.0, 90.0, object_ids=(1, 2, -1), with_points=True), segment_ids=a0.segment_ids
    )
    b0 = make_submap("b", 0, 2.0, 5.0, 180.0, object_ids=(4, 5))
    fig = map_view_figure([a1, b0, a0], title="t")
    (ax,) = fig.axes
    circles = [c for c in ax.collections if isinstance(c, EllipseCollection)]
    assert [len(c.get_offsets()) for c in circles] == [2, 1, 2]  # a: 2 with a true object, 1 without; b: 2
    world_a = transform_points(a1.truth.T_world_submap, a1.centers)[:, :2]
    np.testing.assert_allclose(np.concatenate([c.get_offsets() for c in circles[:2]]), world_a[[0, 1, 2]])
    np.testing.assert_allclose(circles[2].get_offsets(), transform_points(b0.truth.T_world_submap, b0.centers)[:, :2])
    assert circles[0].get_facecolor()[0, 3] > 0 and circles[1].get_facecolor()[0, 3] == 0  # hollow: no true object
    assert ax.get_title() == "t: segment maps from above (true submap poses)\n5 segments in 3 submaps"
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)" and ax.get_aspect() == 1.0
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "robot a",
        "robot b",
        "segment, circle to scale (true object known)",
        "segment with no true object",
        "segment points",
        "submap centres, in order",
    ]
    (scale,) = [t.get_text() for t in ax.texts if t.get_text().endswith(" m")]
    assert scale == "2 m"  # a fifth of the about 14 m wide map, rounded down to 1, 2 or 5 x 10^n
    odom = map_view_figure([s.public() for s in (a0, b0)], frame="odom")
    assert "(each robot's odometry frame)" in odom.axes[0].get_title()
    assert "segment with no true object" not in [t.get_text() for t in odom.axes[0].get_legend().get_texts()]
    p1 = write_map_view(tmp_path / "map.png", [a0, a1, b0])
    first = p1.read_bytes()
    assert _is_png(p1) and write_map_view(tmp_path / "map.png", [a0, a1, b0]).read_bytes() == first
    with pytest.raises(EvaluationError, match="odom"):
        map_view_figure([b0.public()], frame="world")
    with pytest.raises(EvaluationError, match="valid"):
        map_view_figure([b0], frame="map")  # type: ignore[arg-type]
    with pytest.raises(EvaluationError, match="no segments"):
        map_view_figure([make_submap("c", 0, 0.0, 0.0, object_ids=())])


def test_a_map_view_lists_only_the_marks_it_draws_and_its_dense_points_are_an_image_in_the_pdf(make_submap, tmp_path):
    """A map whose every segment lacks a true object draws hollow circles only: the legend used to list the
    filled circle all the same."""
    from dataclasses import replace

    from roman_sim.report.mapview import map_view_figure, write_map_view

    spurious = make_submap("a", 0, 0.0, 0.0, object_ids=(-1,) * 8)
    labels = [t.get_text() for t in map_view_figure([spurious]).axes[0].get_legend().get_texts()]
    assert labels == ["robot a", "segment with no true object", "submap centres, in order"]
    rng = np.random.default_rng(1)
    dense = replace(spurious, points=[c + rng.normal(scale=0.3, size=(150, 3)) for c in spurious.centers])
    write_map_view(tmp_path / "sparse.png", [spurious])
    write_map_view(tmp_path / "dense.png", [dense])  # 8 segments x 100 points (the default cap per segment)
    assert b"/Subtype /Image" not in (tmp_path / "sparse.pdf").read_bytes()  # 8 circles and a path: vectors
    assert b"/Subtype /Image" in (tmp_path / "dense.pdf").read_bytes()  # 800 points: an image inside the PDF


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
