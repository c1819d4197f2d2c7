"""Precision-recall on a chosen score: hand-computed sweeps, operating points and areas; pairs.csv columns."""

from __future__ import annotations

import gzip
from dataclasses import replace

import numpy as np
import pytest
from committed_results import REFERENCE

from roman_sim.core.errors import EvaluationError, StorageError
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import auc, pr_curve
from roman_sim.evaluation.results import PAIRS_FIELDS, read_metrics_json, read_pairs_csv, write_pairs_csv
from roman_sim.evaluation.score_curves import check_score, offered_scores, score_curve, score_summaries, score_summary
from roman_sim.report.recompute import run_score_summaries


def _hand_pairs(make_score):
    """Six pairs of method m: (relevant, correct, n_assoc, conf); the fifth failed and has no ``conf``."""
    rows = [
        ("p1", True, True, 7, 0.9),
        ("p2", True, False, 6, 0.8),
        ("p3", False, False, 3, 0.7),
        ("p4", True, True, 4, 0.6),
        ("p5", True, True, 0, None),
        ("p6", False, True, 5, 0.5),
    ]
    out = []
    for name, rel, ok, n, conf in rows:
        s = make_score(name, rel, n, ok)
        out.append(replace(s, named=() if conf is None else (("conf", conf),)))
    return out


def test_a_named_score_sweeps_its_values_as_computed_by_hand(make_score) -> None:
    c = score_curve(_hand_pairs(make_score), "conf")
    # 4 relevant pairs (p1, p2, p4, p5); p6 is correct but not relevant: neither a hit nor a false positive;
    # p5 has no score and is accepted at no threshold
    assert c.thresholds.tolist() == [0.5, 0.6, 0.7, 0.8, 0.9]
    assert c.n_relevant == 4
    assert c.tp.tolist() == [2, 2, 1, 1, 1]
    assert c.fp.tolist() == [2, 2, 2, 1, 0]
    assert c.precision.tolist() == [0.5, 0.5, 1 / 3, 0.5, 1.0]
    assert c.recall.tolist() == [0.5, 0.5, 0.25, 0.25, 0.25]


def test_operating_points_and_area_on_a_named_score_by_hand(make_score) -> None:
    s = score_summary(_hand_pairs(make_score), "conf")
    # best precision at recall 0.25 is 1, at 0.5 it is 0.5; the curve starts at (0, 1):
    # 0.25 * (1 + 1) / 2 + 0.25 * (1 + 0.5) / 2 = 0.4375
    assert s.auc == pytest.approx(0.4375, abs=1e-15)
    top = s.points["max_recall"]
    assert (top.threshold, top.point.hits, top.point.false_positives) == (0.6, 2, 2)  # highest keeping 2 hits
    for name in ("precision_90", "precision_100"):
        p = s.points[name]
        assert (p.threshold, p.point.hits, p.point.false_positives, p.point.recall) == (0.9, 1, 0, 0.25)


def test_a_threshold_no_score_reaches_is_not_reached(make_score) -> None:
    pairs = [replace(make_score("q1", True, 3, False), named=(("conf", 0.4),))]
    s = score_summary(pairs, "conf")
    assert not s.points["precision_90"].point.reached and s.points["precision_90"].threshold is None
    assert s.auc == 0.0


def test_the_association_count_gives_the_evaluation_own_curve_and_area(make_score) -> None:
    pairs = _hand_pairs(make_score)
    cfg = EvalConfig()
    c, ref = score_curve(pairs, "associations", cfg), pr_curve(pairs, cfg.k_values())
    assert c.thresholds.tolist() == ref.k.tolist()
    assert c.tp.tolist() == ref.tp.tolist() and c.fp.tolist() == ref.fp.tolist()
    assert np.array_equal(c.precision, ref.precision, equal_nan=True)
    assert score_summary(pairs, "associations").auc == auc(ref)


def test_every_method_must_offer_the_chosen_score(make_score) -> None:
    pairs = _hand_pairs(make_score) + [make_score("r1", True, 3, True, method="ransac100k")]
    assert offered_scores(pairs, "m") == ["associations", "conf"]
    assert offered_scores(pairs, "ransac100k") == ["associations"]
    check_score(pairs, "associations")
    with pytest.raises(EvaluationError) as err:
        score_summaries(pairs, "conf")
    assert str(err.value) == "score 'conf': method ransac100k does not offer it (it offers: associations)"


def test_pairs_csv_carries_named_scores_as_columns_and_reads_them_back(make_score, tmp_path) -> None:
    pairs = _hand_pairs(make_score)
    pairs[0] = replace(pairs[0], named=(("conf", 0.9), ("zeta", 2.5)))
    path = write_pairs_csv(tmp_path / "pairs.csv", pairs)
    lines = path.read_text().splitlines()
    assert lines[0] == ",".join([*PAIRS_FIELDS, "score_conf", "score_zeta"])
    assert lines[1].endswith(",0.9,2.5") and lines[5].endswith(",,")  # p5: no score at all
    back = read_pairs_csv(path)
    assert [s.named for s in back] == [s.named for s in pairs]
    assert write_pairs_csv(tmp_path / "again.csv", back).read_bytes() == path.read_bytes()


def test_a_pairs_table_without_named_scores_is_written_and_read_as_before(make_score, tmp_path) -> None:
    pairs = [make_score("p1", True, 4, True), make_score("p2", False, 0, False)]
    path = write_pairs_csv(tmp_path / "pairs.csv", pairs)
    assert path.read_text().splitlines()[0] == ",".join(PAIRS_FIELDS)
    assert [s.named for s in read_pairs_csv(path)] == [(), ()]


def test_committed_results_read_and_their_default_score_is_their_metrics() -> None:
    run = REFERENCE / "demo"
    before = (run / "pairs.csv.gz").read_bytes()
    rows = read_pairs_csv(run / "pairs.csv.gz")
    assert rows and all(s.named == () for s in rows)
    assert "score_" not in gzip.decompress(before).decode().splitlines()[0]
    stored = read_metrics_json(run / "metrics.json")
    for s in run_score_summaries(run, "associations"):
        o = stored.methods[s.method].set(stored.headline).overall
        assert s.auc == o.auc and s.n_relevant == o.n_relevant
        for name in ("max_recall", "precision_90", "precision_100"):
            want = o.operating_points[name]
            got = s.points[name]
            assert want is not None and (got.point.hits, got.point.false_positives) == (want.hits, want.false_positives)
            assert got.threshold == (None if want.k is None else float(want.k))
    with pytest.raises(EvaluationError, match="score 'margin': method clipper does not offer it"):
        run_score_summaries(run, "margin")
    assert (run / "pairs.csv.gz").read_bytes() == before


@pytest.mark.parametrize("cell", ["high", "nan", "inf"])
def test_a_bad_score_cell_is_one_line_naming_the_file_and_line(make_score, tmp_path, cell: str) -> None:
    pairs = [replace(make_score("p1", True, 4, True), named=(("conf", 0.5),))]
    path = write_pairs_csv(tmp_path / "pairs.csv", pairs)
    path.write_text(path.read_text().replace(",0.5\n", f",{cell}\n"))
    with pytest.raises(StorageError, match=r"pairs.csv: line 2: "):
        read_pairs_csv(path)
