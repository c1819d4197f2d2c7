"""Claims of the reference summary on hand-made run summaries: they hold only when the data says so."""

from __future__ import annotations

from roman_sim.core.records import from_json
from roman_sim.studies.claims import claims, claims_markdown, comparison


def _rec(h: int, n: int) -> dict:
    return {
        "max_recall": h / n if n else None,
        "max_hits": h,
        "n_relevant": n,
        "recall_ci": [0.0, 1.0] if n else None,
        "few": n < 5,
    }


def _method(bins: dict[str, tuple[int, int]], overall: tuple[int, int], runtime: float = 0.01) -> dict:
    one = {**_rec(*overall), "bins": {b: _rec(*v) for b, v in bins.items()}}
    return {"inter": one, "intra": {**_rec(0, 0), "bins": {}}, "runtime_median_s": runtime}


def _runs(roman_opp: tuple[int, int], ransac_opp: tuple[int, int]) -> dict:
    return {
        "same_direction": {
            "methods": {
                "roman": _method({"0-60": (9, 10)}, (9, 10), 0.004),
                "ransac1m": _method({"0-60": (8, 10)}, (8, 10), 0.04),
            },
            "map": {},
        },
        "opposite_direction": {
            "methods": {
                "roman": _method({"120-180": roman_opp}, roman_opp, 0.004),
                "ransac1m": _method({"120-180": ransac_opp}, ransac_opp, 0.04),
            },
            "map": {},
        },
        "multi_robot_tunnel": {
            "methods": {},
            "map": {},
            "ate_robots": {"robots": ["a", "b", "c"], "common": ["a"]},
            "ate": {
                "odometry": {"connected": 3, "common": 0.4, "all": 0.6},
                "odometry_no_prior": {"connected": 3, "common": 0.3, "all": 0.35},
                "roman": {"connected": 1, "common": 0.4, "all": None},
                "oracle": {"connected": 3, "common": 0.3, "all": 0.4},
            },
        },
    }


def test_claims_follow_the_numbers(as_summaries):
    by_id = {c.id: c for c in claims(as_summaries(_runs((6, 10), (5, 10))), [])}
    assert by_id["opposite_harder"].holds
    assert by_id["roman_at_or_above_every_baseline"].holds
    assert by_id["roman_faster_than_ransac1m"].holds and "10.0x" in by_id["roman_faster_than_ransac1m"].text
    # ROMAN placed 1 of 3 robots and equals odometry over that robot: neither ATE claim holds
    assert not by_id["roman_ate_below_odometry"].holds and not by_id["roman_places_every_robot"].holds
    assert "multi_robot_tunnel 1/3" in by_id["roman_places_every_robot"].text
    worse = {c.id: c for c in claims(as_summaries(_runs((6, 10), (7, 10))), [])}["roman_at_or_above_every_baseline"]
    assert not worse.holds and "opposite_direction 120-180 deg: roman 0.60 (6/10)" in worse.text
    text = claims_markdown(claims(as_summaries(_runs((6, 10), (7, 10))), []))
    assert text.index(worse.text) > text.index("Where it does not:")


def test_small_bins_are_not_compared_and_cells_carry_counts(as_summaries):
    by_id = {c.id: c for c in claims(as_summaries(_runs((1, 2), (2, 2))), [])}
    assert "(1 comparisons" in by_id["roman_at_or_above_every_baseline"].text  # only the 10-pair bin counts
    rows = {r.figure: r for r in comparison(as_summaries(_runs((1, 2), (2, 2))))}
    assert rows["roman max recall, opposite direction"].cross_robot == "n<5: 1/2"
    assert rows["roman max recall, same direction"].cross_robot == "0.90 (9/10) [0.00, 1.00]"


def _pt(k: int | None, hits: int, n: int, fp: int, reached: bool = True) -> dict:
    """An operating point's JSON (intervals fixed, not computed: the cells only print them)."""
    pos = hits + fp
    return {
        "k": k,
        "reached": reached,
        "hits": hits,
        "n_relevant": n,
        "false_positives": fp,
        "recall": hits / n if n else None,
        "recall_ci": [0.25, 0.75] if n else None,
        "precision": hits / pos if pos else None,
        "precision_ci": [0.2, 0.8] if pos else None,
    }


def test_point_cells_carry_precision_and_threshold():
    from roman_sim.evaluation.run_summary import RecallSummary
    from roman_sim.studies.claims import mcell, pcell, point_cells

    points = {
        "max_recall": _pt(3, 9, 10, 11),  # P 9/20
        "precision_90": _pt(7, 6, 10, 0),
        "precision_100": _pt(None, 0, 10, 0, reached=False),
        "acceptance": _pt(4, 8, 10, 0),
    }
    r = from_json(RecallSummary, {**_rec(9, 10), "points": points}, "test")
    assert point_cells(r) == [
        "0.90 (9/10) [0.25, 0.75] P 0.45 k 3",
        "0.60 (6/10) [0.25, 0.75] P 1.00 k 7",
        "not reached (0/10)",
        "0.80 (8/10) [0.25, 0.75] P 1.00 k 4",
    ]
    assert mcell(r) == "0.90 (9/10) [0.25, 0.75] P 0.45 k 3"
    small = from_json(
        RecallSummary, {**_rec(1, 2), "points": {"max_recall": _pt(2, 1, 2, 1), "acceptance": _pt(4, 0, 2, 0)}}, "test"
    )
    assert point_cells(small) == ["n<5: 1/2 P 0.50 k 2", "n/a", "n/a", "n<5: 0/2 P n/a k 4"]
    assert (
        pcell(
            from_json(RecallSummary, {**_rec(0, 0), "points": {"max_recall": _pt(0, 0, 0, 3)}}, "test").points[
                "max_recall"
            ]
        )
        == "n/a"
    )
    # a summary written before the points: max recall as before, the other points n/a
    old = from_json(RecallSummary, _rec(9, 10), "test")
    assert mcell(old) == "0.90 (9/10) [0.00, 1.00]" and point_cells(old) == ["n/a"] * 4


def test_comparison_cells_give_max_recall_with_its_precision(as_summaries):
    runs = _runs((6, 10), (5, 10))
    runs["same_direction"]["methods"]["roman"]["inter"]["points"] = {"max_recall": _pt(2, 9, 10, 1)}
    rows = {r.figure: r for r in comparison(as_summaries(runs))}
    assert rows["roman max recall, same direction"].cross_robot == "0.90 (9/10) [0.25, 0.75] P 0.90 k 2"
    assert rows["ransac1m max recall, same direction"].cross_robot == "0.80 (8/10) [0.00, 1.00]"


def _acceptance(hits: int, fp: int) -> dict:
    """The visual method's cross-robot set with only its acceptance point (k = 6)."""
    point = {
        "k": 6,
        "reached": True,
        "hits": hits,
        "n_relevant": 20,
        "false_positives": fp,
        "recall": hits / 20,
        "recall_ci": [0.0, 1.0],
        "precision": hits / (hits + fp) if hits + fp else None,
        "precision_ci": [0.0, 1.0] if hits + fp else None,
    }
    one = {**_rec(hits, 20), "bins": {}, "points": {"acceptance": point}}
    return {"inter": one, "intra": {**_rec(0, 0), "bins": {}}, "runtime_median_s": 0.01}


def test_visual_closures_claim_counts_correct_over_accepted(as_summaries):
    def claim(tunnel: tuple[int, int], paper: tuple[int, int]) -> dict:
        runs = {
            "multi_robot_tunnel": {"methods": {"visual": _acceptance(*tunnel)}, "map": {}},
            "kimera_outdoor": {"methods": {"visual": _acceptance(*paper)}, "map": {}},
            "same_direction": {"methods": {"visual": _acceptance(0, 9)}, "map": {}},  # not multi-robot: not read
        }
        return {c.id: c for c in claims(as_summaries(runs), [])}["visual_closures_correct"]

    ok = claim((8, 2), (40, 5))  # 8 of 10 is exactly 80 %
    assert ok.holds, ok.text
    assert "multi_robot_tunnel 0.80 (8/10, k = 6)" in ok.text and "kimera_outdoor 0.89 (40/45, k = 6)" in ok.text
    assert "same_direction" not in ok.text
    assert not claim((7, 2), (40, 5)).holds  # 7 of 9 = 0.78
    none = claim((0, 0), (40, 5))
    assert not none.holds and "multi_robot_tunnel: no closure (k = 6)" in none.text
