"""Table I, the two-front-end table and the front-end summary on hand-made run summaries (exact cells)."""

from __future__ import annotations

from roman_sim.evaluation.grades import CosineStats, DescriptorGrades, FrontEndGrades, SegmentationGrades
from roman_sim.evaluation.run_summary import frontend_summary
from roman_sim.studies.claims import claims
from roman_sim.studies.reference_tables import AteCell, frontends, frontends_markdown, table1, table1_markdown


def _ate(**rows: tuple[int, float | None]) -> dict:
    """Rows ``name=(robots placed, ATE over the common robots)``; over all robots: 10x that, if all 3 placed."""
    return {
        v: {"connected": n, "common": c, "all": None if n < 3 or c is None else 10 * c} for v, (n, c) in rows.items()
    }


def _multi(ate: dict, common: list[str]) -> dict:
    return {"methods": {}, "map": {}, "ate": ate, "ate_robots": {"robots": ["a", "b", "c"], "common": common}}


def _runs_ate() -> dict:
    # tunnel: combined lowest, ROMAN below visual; hybrid: visual placed 2 robots, combined above ROMAN
    tunnel = _multi(
        _ate(
            odometry=(3, 0.5),
            odometry_no_prior=(3, 0.45),
            roman=(3, 0.3),
            visual=(3, 0.4),
            combined=(3, 0.25),
            oracle=(3, 0.2),
        ),
        ["a", "b", "c"],
    )
    hybrid = _multi(
        _ate(
            odometry=(3, 0.6),
            odometry_no_prior=(3, 0.55),
            roman=(3, 0.35),
            visual=(2, 0.5),
            combined=(3, 0.4),
            oracle=(3, 0.3),
        ),
        ["a", "c"],
    )
    return {"multi_robot_tunnel": tunnel, "multi_robot_hybrid": hybrid}


def test_table1_puts_every_row_next_to_the_paper(as_summaries):
    rows = table1(as_summaries(_runs_ate()))
    assert [r.environment for r in rows] == ["tunnel", "hybrid"]  # the paper's order; outdoor did not run
    assert rows[0].paper == {"visual": 4.38, "roman": 4.20, "combined": 4.12}
    assert rows[1].simulation["visual"] == AteCell(ate_m=0.5, ate_all_m=None, placed=2)
    assert rows[1].common == ["a", "c"] and rows[1].robots == ["a", "b", "c"]
    lines = table1_markdown(rows).splitlines()
    assert lines[-4] == (
        "| tunnel | 4.38 | 4.20 | 4.12 | 0.50 (3/3) | 0.45 (3/3) | 0.40 (3/3) | 0.30 (3/3) | "
        "0.25 (3/3) | 0.20 (3/3) | a, b, c of 3 |"
    )
    assert lines[-2] == (
        "| hybrid | 5.83 | 5.12 | 4.77 | 0.60 (3/3) | 0.55 (3/3) | 0.50 (2/3) | 0.35 (3/3) | "
        "0.40 (3/3) | 0.30 (3/3) | a, c of 3 |"
    )
    assert lines[-1] == (
        "| hybrid, all robots |  |  |  | 6.00 (3/3) | 5.50 (3/3) | n/a (2/3) | 3.50 (3/3) | "
        "4.00 (3/3) | 3.00 (3/3) | a, b, c |"
    )


def test_table1_marks_rows_a_run_does_not_have(as_summaries):
    runs = {"multi_robot_outdoor": _multi(_ate(odometry=(3, 0.5), roman=(2, None)), [])}
    row = table1(as_summaries(runs))[0]
    assert row.simulation["visual"] == AteCell(ate_m=None, ate_all_m=None, placed=None)
    assert table1_markdown([row]).splitlines()[-2] == (
        "| outdoor | 9.38 | 8.77 | 7.77 | 0.50 (3/3) | n/a | n/a | n/a (2/3) | n/a | n/a | none of 3 |"
    )
    assert table1_markdown([]) == ""


def test_table1_claims_follow_the_rows(as_summaries):
    by_id = {c.id: c for c in claims(as_summaries(_runs_ate()), [])}
    below, lowest = by_id["roman_ate_below_visual"], by_id["combined_ate_lowest"]
    assert below.holds  # 0.30 < 0.40 and 0.35 < 0.50
    assert "multi_robot_hybrid: ROMAN 0.35 vs visual 0.50 m over 2/3 robots" in below.text
    assert "tunnel 4.38 / 4.20 / 4.12" in below.text
    assert not lowest.holds  # hybrid: combined 0.40 > ROMAN 0.35
    assert "multi_robot_tunnel: combined 0.25, visual 0.40, ROMAN 0.30 m over 3/3 robots" in lowest.text
    whole = by_id["combined_all_robots_below_odometry"]  # over all robots: 10x the common figures here
    assert whole.holds
    assert "multi_robot_tunnel: combined 2.50 m (3/3 robots placed) vs odometry 5.00 m" in whole.text
    runs = _runs_ate()
    runs["multi_robot_tunnel"]["ate"]["combined"].update(connected=2, all=None)  # a robot left out: no all-robot ATE
    assert not {c.id: c for c in claims(as_summaries(runs), [])}["combined_all_robots_below_odometry"].holds
    runs = _runs_ate()
    runs["multi_robot_hybrid"]["ate"]["combined"]["common"] = 0.354  # within 5 mm of ROMAN: a tie, "at or below"
    assert {c.id: c for c in claims(as_summaries(runs), [])}["combined_ate_lowest"].holds
    runs["multi_robot_hybrid"]["ate"]["visual"]["common"] = 0.354  # ROMAN 0.35 is then not lower than visual
    assert not {c.id: c for c in claims(as_summaries(runs), [])}["roman_ate_below_visual"].holds
    no_visual = {"multi_robot_tunnel": _multi(_ate(odometry=(3, 0.5), roman=(3, 0.3)), ["a"])}
    assert not {c.id for c in claims(as_summaries(no_visual), [])} & {
        "roman_ate_below_visual",
        "combined_ate_lowest",
        "combined_all_robots_below_odometry",
    }


def _rec(h: int, n: int, ci: tuple[float, float] | None = (0.1, 0.9)) -> dict:
    return {
        "max_recall": h / n if n else None,
        "max_hits": h,
        "n_relevant": n,
        "recall_ci": list(ci) if n and ci else None,
        "few": n < 5,
    }


def _opp(bins: dict[str, tuple[int, int]], frontend: dict | None) -> dict:
    hits, rel = sum(h for h, _ in bins.values()), sum(n for _, n in bins.values())
    method = {
        "inter": {**_rec(hits, rel), "n_pairs": 100, "bins": {b: _rec(*v) for b, v in bins.items()}},
        "intra": {**_rec(0, 0), "bins": {}},
        "runtime_median_s": 0.01,
    }
    return {
        "methods": {"roman": method, "clipper": method, "visual": method},
        "map": {},
        "frontend": frontend,
        "pairs": {"inter": {"n_pairs": 100, "n_relevant": 12}},
    }


GRADES = {
    "segmenter": "image",
    "encoder": "image",
    "frames": 40,
    "objects": 300,
    "masks": 250,
    "precision": 0.6,
    "recall": 0.5,
    "mean_iou": 0.7,
    "over_segmented": 7,
    "under_segmented": 3,
    "spurious": 11,
    "cosine_same_instance": 0.9,
    "cosine_same_family": 0.8,
    "cosine_other_family": 0.625,
}


def test_two_front_ends_share_pairs_and_show_grades(as_summaries):
    truth = {**GRADES, "segmenter": "fastsam", "encoder": "simulated", "precision": 1.0}
    runs = {
        "opposite_direction": _opp({"60-120": (1, 2), "120-180": (6, 10)}, truth),
        "opposite_direction_pixels": _opp({"60-120": (0, 2), "120-180": (3, 10)}, GRADES),
    }
    t = frontends(as_summaries(runs))
    assert t is not None and t.same_pairs and t.scenarios == ["opposite_direction", "opposite_direction_pixels"]
    assert [(r.scenario, r.method) for r in t.recall] == [  # ROMAN first; visual uses no segments
        ("opposite_direction", "roman"),
        ("opposite_direction_pixels", "roman"),
        ("opposite_direction", "clipper"),
        ("opposite_direction_pixels", "clipper"),
    ]
    lines = frontends_markdown(t).splitlines()
    assert "| front end | method | 60-120 deg | 120-180 deg | all |" in lines
    assert (
        "| opposite_direction_pixels (image + image) | roman | n<5: 0/2 | 0.30 (3/10) [0.10, 0.90] | "
        "0.25 (3/12) [0.10, 0.90] |"
    ) in lines
    assert (
        "| opposite_direction (fastsam + simulated) | clipper | n<5: 1/2 | 0.60 (6/10) [0.10, 0.90] | "
        "0.58 (7/12) [0.10, 0.90] |" in lines
    )
    assert (
        lines[-1] == "| opposite_direction_pixels (image + image) | 40 | 0.60 | 0.50 | 0.70 | 7 | 3 | 0.90 | "
        "0.80 | 0.62 |"
    )
    assert "100 cross-robot pairs (12 relevant), the same pairs in every row" in frontends_markdown(t)
    runs["opposite_direction_pixels"]["pairs"] = {"inter": {"n_pairs": 99, "n_relevant": 12}}
    assert "NOT the same pair counts" in frontends_markdown(frontends(as_summaries(runs)))
    assert frontends(as_summaries({"same_direction": runs["opposite_direction"]})) is None
    assert frontends_markdown(None) == ""


def test_frontend_summary_weights_other_families_by_pairs():
    cls = {
        "same_instance": CosineStats(4, 0.9, None, None, None, []),
        "same_family": CosineStats(10, 0.8, None, None, None, []),
        "same_group": CosineStats(1, 0.7, None, None, None, []),
        "other_group": CosineStats(3, 0.5, None, None, None, []),
    }
    # one area bin; distance bins [0, 7.5) (the mapper's range) and beyond: the headline counts the first
    seg = SegmentationGrades(frames=2, objects=9, masks=8, over_segmented=1, under_segmented=2)
    seg.distance_edges_m, seg.table_objects, seg.table_matched = [0.0, 7.5], [[8, 1]], [[4, 0]]
    seg.dist_graded_masks, seg.dist_matched_masks, seg.dist_iou_sum = [8, 0], [6, 0], [3.0, 0.0]
    desc = DescriptorGrades(10, cls, [], [], [])
    s = frontend_summary(FrontEndGrades("image", "image", seg, desc))
    assert s is not None and s.cosine_other_family == (0.7 + 3 * 0.5) / 4 and s.cosine_same_instance == 0.9
    assert (s.precision, s.recall, s.mean_iou, s.over_segmented, s.frames) == (0.75, 0.5, 0.5, 1, 2)
    cls["same_group"].pairs = cls["other_group"].pairs = 0
    no_desc = frontend_summary(FrontEndGrades("perfect", None, seg, None))
    assert no_desc is not None and no_desc.cosine_same_family is None and no_desc.encoder is None
    other = frontend_summary(FrontEndGrades("x", None, seg, desc))
    assert other is not None and other.cosine_other_family is None
    assert frontend_summary(None) is None


def _pt(k: int | None, hits: int, n: int, fp: int, reached: bool = True) -> dict:
    pos = hits + fp
    return {
        "k": k,
        "reached": reached,
        "hits": hits,
        "n_relevant": n,
        "false_positives": fp,
        "recall": hits / n if n else None,
        "recall_ci": [0.1, 0.9] if n else None,
        "precision": hits / pos if pos else None,
        "precision_ci": [0.2, 0.8] if pos else None,
    }


def _with_points(rec: dict, hits: int, n: int) -> dict:
    """``rec`` with operating points: max recall at k 2 (one false positive), P>=0.9 at k 6 with one
    hit fewer, P=1 never, acceptance at k 4 with the hits of max recall and no false positive."""
    points = {
        "max_recall": _pt(2, hits, n, 1),
        "precision_90": _pt(6, max(hits - 1, 0), n, 0),
        "precision_100": _pt(None, 0, n, 0, reached=False),
        "acceptance": _pt(4, hits, n, 0),
    }
    return {**rec, "points": points}


def test_operating_points_table_per_method_and_bin(as_summaries):
    from roman_sim.studies.reference_tables import operating_points, operating_points_markdown

    runs = {"opposite_direction": _opp({"0-60": (0, 0), "60-120": (1, 2), "120-180": (6, 10)}, None)}
    for m in runs["opposite_direction"]["methods"].values():
        inter = m["inter"]
        inter.update(_with_points(inter, 7, 12))
        inter["bins"] = {b: _with_points(r, r["max_hits"], r["n_relevant"]) for b, r in inter["bins"].items()}
    rows = operating_points(as_summaries({**runs, "multi_robot_tunnel": _multi({}, [])}))
    # ROMAN first; all pairs, then the bins with relevant pairs in heading order; the ATE scenario is not listed
    assert [(r.method, r.heading) for r in rows] == [
        (m, h) for m in ("roman", "clipper", "visual") for h in ("all", "60-120", "120-180")
    ]
    lines = operating_points_markdown(rows).splitlines()
    assert (
        "| scenario | method | heading | max recall | recall at P>=0.9 | recall at P=1 | recall at acceptance |"
        in lines
    )
    assert "|---|---|---|---|---|---|---|" in lines
    assert (
        "| opposite_direction | roman | all | 0.58 (7/12) [0.10, 0.90] P 0.88 k 2 | "
        "0.50 (6/12) [0.10, 0.90] P 1.00 k 6 | not reached (0/12) | 0.58 (7/12) [0.10, 0.90] P 1.00 k 4 |"
    ) in lines
    assert (
        "| opposite_direction | clipper | 60-120 deg | n<5: 1/2 P 0.50 k 2 | n<5: 0/2 P n/a k 6 | "
        "not reached (0/2) | n<5: 1/2 P 1.00 k 4 |"
    ) in lines
    assert "P>=0.9 and at P=1 at the smallest k" in operating_points_markdown(rows)
    assert operating_points_markdown([]) == "" and operating_points(as_summaries({})) == []
    # the front-end table's cells then carry max recall's precision and threshold too
    runs["opposite_direction_pixels"] = runs["opposite_direction"]
    t = frontends(as_summaries(runs))
    assert (
        "| opposite_direction | roman | n/a | n<5: 1/2 P 0.50 k 2 | 0.60 (6/10) [0.10, 0.90] P 0.86 k 2 | "
        "0.58 (7/12) [0.10, 0.90] P 0.88 k 2 |"
    ) in frontends_markdown(t).splitlines()
