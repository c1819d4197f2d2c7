"""The independent scorer: its definitions by hand, and its agreement with every committed run.

The scorer (``roman_sim.studies.independent_scorer``) shares no code with the evaluation that produced the
committed figures; these tests check it first on inputs whose answers are worked out by hand,
then re-derive every committed run's summary figures and every claim from the raw files.
"""

from __future__ import annotations

import copy
import csv
import dataclasses
import gzip
import io
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from committed_results import REFERENCE as REF

from roman_sim.core.records import from_json, to_json
from roman_sim.studies import independent_scorer as S

CFG = S.Settings("distance", 10.0, 3, 5.0, 1.0, 0, 30, (0.0, 60.0, 120.0, 180.0), 5, 0.95)


def test_the_scorer_imports_no_scoring_code():
    import grimp

    graph = grimp.build_graph("roman_sim")
    imported = graph.find_upstream_modules(
        "roman_sim.studies.independent_scorer"
    )  # everything it imports, transitively
    assert imported <= {"roman_sim.core.errors", "roman_sim.core.yamlio"}, sorted(imported)


def test_wilson_interval_by_hand():
    # 5 of 10 at 95 %: centre 0.5, half-width z/(1+z^2/n) * sqrt(0.025 + z^2/400), z = 1.959964
    lo, hi = S.wilson_interval(5, 10, 0.95)
    assert lo == pytest.approx(0.236593, abs=1e-6) and hi == pytest.approx(0.763407, abs=1e-6)
    assert S.wilson_interval(0, 4, 0.95)[0] == 0.0 and S.wilson_interval(4, 4, 0.95)[1] == pytest.approx(1.0)
    assert S.wilson_interval(0, 0, 0.95) is None


def test_pose_errors_by_hand():
    T_true = S.pose_4dof(1.0, 2.0, 0.5, 0.3)
    T_est = S.pose_4dof(1.3, 2.4, 0.5, 0.3 + math.radians(4.0))
    rot, trans = S.pose_errors(T_est, T_true)
    assert rot == pytest.approx(4.0, abs=1e-6) and trans == pytest.approx(0.5, abs=1e-12)


def test_heading_bins_are_half_open_but_the_last():
    edges = (0.0, 60.0, 120.0, 180.0)
    assert [S.heading_bin(v, edges) for v in (0.0, 59.999, 60.0, 120.0, 180.0, 180.1, float("nan"))] == [
        0,
        0,
        1,
        2,
        2,
        -1,
        -1,
    ]


def _judged(rows: list[tuple[bool, bool, int]]) -> list[S.Judged]:
    return [S.Judged(rel, ok, n, 10.0) for rel, ok, n in rows]


def test_recall_record_by_hand():
    # relevant+correct with 8, 5 and 2 associations; a wrong estimate with 4; a relevant pair
    # nobody got (0 assoc); an irrelevant correct one with 9 (neither TP nor FP).
    rows = _judged([(True, True, 8), (True, True, 5), (True, True, 2), (False, False, 4), (True, False, 0)])
    rows += _judged([(False, True, 9)])
    r = S.recall_record(rows, CFG)
    # k <= 2: TP 3 (max), FP 2 (the wrong one at 4 and the relevant miss at 0 counts for k = 0 only)
    assert r["max_hits"] == 3 and r["n_relevant"] == 4 and r["max_recall"] == 0.75
    # FP = 0 from k = 5 on (the wrong estimate has 4): TP(5) = 2
    assert r["hits_at_precision_1"] == 2 and r["recall_at_precision_1"] == 0.5
    assert r["few"] is True  # 4 relevant < 5
    assert r["recall_ci"] == S.wilson_interval(3, 4, 0.95)


CFG_ACC = S.Settings("distance", 10.0, 3, 5.0, 1.0, 0, 30, (0.0, 60.0, 120.0, 180.0), 5, 0.95, 4)
#: (relevant, correct, n_assoc): TP(k) = 2 for k <= 5, 1 for k <= 10; FP(k) = 4 at k = 0, 3 up to k = 2,
#: 2 at k = 3, then 1 (the n=8 wrong estimate) up to k = 8, 0 from k = 9
SIX = [(True, True, 10), (True, True, 5), (True, False, 3), (True, False, 0), (False, False, 8), (False, False, 2)]


def test_operating_points_by_hand():
    pts = S.operating_points(_judged(SIX), CFG_ACC)
    assert list(pts) == ["max_recall", "precision_90", "precision_100", "acceptance"]
    # max recall: 2 hits, kept up to k = 5 (the highest such k), where the n=8 pair is the one false positive
    assert pts["max_recall"] == {
        "k": 5,
        "reached": True,
        "hits": 2,
        "n_relevant": 4,
        "false_positives": 1,
        "recall": 0.5,
        "recall_ci": S.wilson_interval(2, 4, 0.95),
        "precision": 2 / 3,
        "precision_ci": S.wilson_interval(2, 3, 0.95),
    }
    for name in ("precision_90", "precision_100"):  # first at k = 9: the n=10 hit alone
        p = pts[name]
        assert (p["k"], p["reached"], p["hits"], p["false_positives"], p["recall"], p["precision"]) == (
            9,
            True,
            1,
            0,
            0.25,
            1.0,
        )
        assert p["precision_ci"] == S.wilson_interval(1, 1, 0.95)
    acc = pts["acceptance"]  # k = 4: the n=10 and n=5 hits, the n=8 miss
    assert (acc["k"], acc["hits"], acc["false_positives"], acc["recall"], acc["precision"]) == (4, 2, 1, 0.5, 2 / 3)
    # the acceptance threshold is used as given, also beyond the sweep; without one there is no such point
    far = S.operating_points(_judged(SIX), dataclasses.replace(CFG_ACC, acceptance_k=50))["acceptance"]
    assert (far["k"], far["hits"], far["false_positives"], far["recall"], far["precision"]) == (50, 0, 0, 0.0, None)
    assert "acceptance" not in S.operating_points(_judged(SIX), CFG)


def test_operating_points_compare_precision_in_fractions():
    # 27 hits and 3 wrong positives: 27/30 is 0.9 exactly (0.9 * 30 is not 27 in floats)
    rows = _judged([(True, i < 27, 5) for i in range(30)])
    pts = S.operating_points(rows, CFG)
    p90 = pts["precision_90"]
    assert (p90["reached"], p90["k"], p90["hits"], p90["false_positives"]) == (True, 0, 27, 3)
    p100 = pts["precision_100"]
    assert p100 == {
        "k": None,
        "reached": False,
        "hits": 0,
        "n_relevant": 30,
        "false_positives": 0,
        "recall": 0.0,
        "recall_ci": S.wilson_interval(0, 30, 0.95),
        "precision": None,
        "precision_ci": None,
    }
    assert pts["max_recall"]["k"] == 5  # 27 hits up to k = 5


def test_operating_points_without_relevant_pairs_or_thresholds():
    # no relevant pair: recall undefined, precision defined where there is a positive
    pts = S.operating_points(_judged([(False, False, 5), (False, False, 0)]), dataclasses.replace(CFG, acceptance_k=2))
    best = pts["max_recall"]  # no hit at all: the lowest threshold
    assert (best["k"], best["hits"], best["false_positives"], best["recall"], best["recall_ci"]) == (
        0,
        0,
        2,
        None,
        None,
    )
    assert best["precision"] == 0.0 and pts["acceptance"]["precision"] == 0.0 and pts["acceptance"]["recall"] is None
    assert not pts["precision_90"]["reached"] and pts["precision_90"]["precision"] is None
    # no pair at all: nothing is positive
    empty = S.operating_points([], CFG)
    assert (empty["max_recall"]["k"], empty["max_recall"]["precision"]) == (0, None)
    # an empty sweep (k_min > k_max): no point reached
    none = S.operating_points(_judged(SIX), dataclasses.replace(CFG, k_min=5, k_max=4))
    assert all(not p["reached"] and p["k"] is None for p in none.values())


def _evaluation_points(rows: list[tuple[bool, bool, int]], cfg: S.Settings, headings: list[float]) -> dict:
    """The evaluation's operating points (overall and per coarse bin) of the same rows, as JSON."""
    from roman_sim.evaluation.config import EvalConfig
    from roman_sim.evaluation.metrics import PairScore, compute_metrics
    from roman_sim.evaluation.pairs import PairTruth

    scores = [
        PairScore(
            PairTruth(
                f"a/{i}", f"b/{i}", "a", "b", 0, i, np.eye(4), 1.0 if rel else 50.0, h, 0.5, float("nan"), rel, "inter"
            ),
            "m",
            n,
            0.1 if ok else 40.0,
            0.1 if ok else 40.0,
            ok,
            0.0,
        )
        for i, ((rel, ok, n), h) in enumerate(zip(rows, headings))
    ]
    ec = EvalConfig(
        k_min=cfg.k_min, k_max=cfg.k_max, heading_bins_deg=list(cfg.heading_bins_deg), min_relevant=cfg.min_relevant
    )
    ps = compute_metrics(scores, ec, acceptance_k=cfg.acceptance_k).method("m").set("inter")
    out = {"all": to_json(ps.overall)["operating_points"]}
    out.update({b.label: to_json(b.stats)["operating_points"] for b in ps.heading_bins})
    return {k: {n: p for n, p in v.items() if p is not None} for k, v in out.items()}


def _scorer_points(rows: list[tuple[bool, bool, int]], cfg: S.Settings, headings: list[float]) -> dict:
    judged = [S.Judged(rel, ok, n, h) for (rel, ok, n), h in zip(rows, headings)]
    figures = S.method_figures(judged, ["inter"] * len(rows), cfg)["inter"]
    return {"all": figures["points"], **{b: r["points"] for b, r in figures["bins"].items()}}


def test_scorer_points_are_the_evaluations_on_hand_made_and_random_rows():
    headings = [10.0, 70.0, 150.0, 170.0, 20.0, 100.0]
    mine, theirs = _scorer_points(SIX, CFG_ACC, headings), _evaluation_points(SIX, CFG_ACC, headings)
    assert set(mine) == set(theirs) == {"all", "0-60", "60-120", "120-180"}
    assert not S.agreement(theirs, mine) and not S.agreement(mine, theirs)
    assert mine["0-60"]["max_recall"]["k"] == 10  # the n=10 hit and the n=8 miss: both kept up to k = 8, the hit to 10
    rng = np.random.default_rng(7)
    for trial in range(40):
        n = int(rng.integers(1, 40))  # the evaluation knows a method by its rows
        rows = [(bool(rng.random() < 0.6), bool(rng.random() < 0.5), int(rng.integers(0, 14))) for _ in range(n)]
        heads = [float(h) for h in rng.uniform(0.0, 180.0, n)]
        cfg = dataclasses.replace(CFG_ACC, k_max=int(rng.integers(0, 16)), acceptance_k=int(rng.integers(0, 20)))
        mine, theirs = _scorer_points(rows, cfg, heads), _evaluation_points(rows, cfg, heads)
        assert set(mine) == set(theirs), trial
        assert not S.agreement(theirs, mine), (trial, S.agreement(theirs, mine)[:5])


def test_umeyama_recovers_a_rigid_transform():
    rng = np.random.default_rng(3)
    est = rng.normal(size=(50, 3))
    R = S.pose_4dof(0.0, 0.0, 0.0, 1.1)[:3, :3]
    ref = est @ R.T + np.array([4.0, -2.0, 1.0])
    assert np.max(S.umeyama_residuals(est, ref)) < 1e-9
    noisy = ref + rng.normal(scale=0.1, size=ref.shape)
    # 0.1 m per axis: about 0.1 * sqrt(3) m in 3D, a little less after the fit absorbs 6 degrees of freedom
    assert np.sqrt(np.mean(S.umeyama_residuals(est, noisy) ** 2)) < 0.1 * math.sqrt(3)


def _write_run(
    d: Path, rows: list[dict[str, object]], estimates: list[dict[str, object]], acceptance: int | None = None
) -> None:
    d.mkdir(parents=True)
    posegraph = "" if acceptance is None else f"posegraph:\n  lc_association_thresh: {acceptance}\n"
    (d / "config.yaml").write_text(
        posegraph + "evaluation:\n  relevance: distance\n  relevant_dist_m: 10.0\n  min_shared_objects: 3\n"
        "  rot_tol_deg: 5.0\n  trans_tol_m: 1.0\n  k_min: 0\n  k_max: 30\n"
        "  heading_bins_deg: [0.0, 60.0, 120.0, 180.0]\n  min_relevant: 1\n  interval_level: 0.95\n"
    )
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(S.PAIR_FIELDS))
    w.writeheader()
    w.writerows(rows)
    (d / "pairs.csv.gz").write_bytes(gzip.compress(buf.getvalue().encode()))
    (d / "alignments.json").write_text(json.dumps({"schema": "x", "alignments": estimates}))


def _row(a: str, b: str, dist: float, heading: float, method: str, n: int) -> dict[str, object]:
    return {
        "a": a,
        "b": b,
        "kind": "inter",
        "center_dist_m": dist,
        "heading_diff_deg": heading,
        "shared_objects": 4,
        "true_x_m": 3.0,
        "true_y_m": 0.0,
        "true_z_m": 0.0,
        "true_yaw_rad": math.radians(heading),
        "method": method,
        "n_assoc": n,
    }


def test_score_run_recomputes_correctness_from_the_estimates(tmp_path):
    good = S.pose_4dof(3.2, 0.0, 0.0, math.radians(150.0)).tolist()  # 0.2 m off: correct
    off = S.pose_4dof(3.0, 0.0, 0.0, math.radians(157.0)).tolist()  # 7 deg off: wrong
    rows = [_row("a/0", "b/0", 4.0, 150.0, "m", 6), _row("a/1", "b/1", 6.0, 150.0, "m", 7)]
    rows += [_row("a/2", "b/2", 30.0, 20.0, "m", 0)]
    est = [
        {"a": "a/0", "b": "b/0", "method": "m", "T_a_b": good},
        {"a": "a/1", "b": "b/1", "method": "m", "T_a_b": off},
        {"a": "a/2", "b": "b/2", "method": "m", "T_a_b": None},
    ]
    _write_run(tmp_path / "run", rows, est)
    out = S.score_run(tmp_path / "run")
    inter = out["methods"]["m"]["inter"]
    assert (inter["max_hits"], inter["n_relevant"], inter["hits_at_precision_1"]) == (1, 2, 0)
    assert inter["bins"]["120-180"]["n_relevant"] == 2 and inter["bins"]["0-60"]["n_relevant"] == 0
    assert out["pairs"]["inter"] == {"n_pairs": 3, "n_relevant": 2}
    # the config has no pose graph section: no acceptance point; max recall at k = 6 (the hit has 6)
    assert list(inter["points"]) == ["max_recall", "precision_90", "precision_100"]
    best = inter["points"]["max_recall"]
    assert (best["k"], best["hits"], best["false_positives"], best["precision"]) == (6, 1, 1, 0.5)
    assert not inter["points"]["precision_90"]["reached"]  # the wrong n=7 estimate outranks the hit
    assert inter["bins"]["0-60"]["points"]["max_recall"]["recall"] is None  # no relevant pair in that bin
    _write_run(tmp_path / "acc", rows, est, acceptance=7)
    acc = S.score_run(tmp_path / "acc")["methods"]["m"]["inter"]["points"]["acceptance"]
    assert (acc["k"], acc["hits"], acc["false_positives"], acc["precision"]) == (7, 0, 1, 0.0)


def test_packets_rebuild_the_mapping_packet_sizes(tmp_path):
    from roman_sim.align.synthetic import make_submap_pair
    from roman_sim.mapping.io import packet_bytes
    from roman_sim.studies.raw_data import packet_file_arrays

    a, b, _ = make_submap_pair(seed=1, n_inliers=8, n_outliers_a=3, n_outliers_b=2)
    np.savez_compressed(tmp_path / "r.npz", **packet_file_arrays([a]))
    assert S.packet_sizes(tmp_path / "r.npz") == [packet_bytes(a)]


# -- the committed reference results ---------------------------------------------------------
def _summary() -> dict:
    return json.loads((REF / "summary.json").read_text(encoding="utf-8"))


def _scenarios() -> list[str]:
    return sorted(_summary()["runs"]) if (REF / "summary.json").is_file() else []


needs_reference = pytest.mark.skipif(not (REF / "summary.json").is_file(), reason="no committed reference results")


@needs_reference
@pytest.mark.parametrize("scenario", _scenarios())
def test_every_committed_run_agrees_with_the_independent_scorer(scenario):
    d = REF / scenario
    assert (d / "runtimes.csv.gz").is_file(), "per-pair runtimes are kept in the raw data"
    assert (d / "packets").is_dir(), "the submap packets are kept in the raw data"
    scored = S.score_run(d)
    assert {"methods", "pairs", "map"} <= set(scored)
    assert all("runtime_median_s" in m for m in scored["methods"].values())
    diffs = S.agreement(_summary()["runs"][scenario], scored)
    assert not diffs, diffs[:10]


@pytest.mark.skipif(not (REF / "demo" / "pairs.csv.gz").is_file(), reason="no committed demo run")
def test_scorer_points_are_the_evaluations_on_the_committed_demo():
    """On real raw files: the evaluation's points (recomputed from the pairs table) are the scorer's."""
    from roman_sim.studies.reference import demo_summary

    evaluated, scored = json.loads(json.dumps(to_json(demo_summary(REF)))), S.score_run(REF / "demo")
    assert not S.agreement(evaluated, scored)
    for m, figures in scored["methods"].items():
        for kind in ("inter", "intra"):
            theirs = evaluated["methods"][m][kind]
            assert not S.agreement(figures[kind]["points"], theirs["points"]), (m, kind)  # and the other way round
            for b, rec in figures[kind]["bins"].items():
                assert not S.agreement(rec["points"], theirs["bins"][b]["points"]), (m, kind, b)
    roman = scored["methods"]["roman"]["inter"]["points"]
    assert (
        roman["acceptance"]["k"] == 4 and roman["max_recall"]["hits"] == scored["methods"]["roman"]["inter"]["max_hits"]
    )


def _without_points(v: object) -> object:
    if isinstance(v, dict):
        return {k: _without_points(x) for k, x in v.items() if k not in ("operating_points", "acceptance_k")}
    if isinstance(v, list):
        return [_without_points(x) for x in v]
    return v


@pytest.mark.skipif(not (REF / "demo" / "pairs.csv.gz").is_file(), reason="no committed demo run")
def test_a_run_whose_metrics_predate_the_points_is_checked_without_them(tmp_path):
    from roman_sim.report.recompute import stored_summary
    from roman_sim.studies.verify import independent_check, verify_run

    d = tmp_path / "demo"
    shutil.copytree(REF / "demo", d)
    metrics = json.loads((d / "metrics.json").read_text(encoding="utf-8"))
    assert "acceptance_k" in metrics  # the committed run has them; the copy is made older
    (d / "metrics.json").write_text(json.dumps(_without_points(metrics)), encoding="utf-8")
    assert not any(s.points for m in stored_summary(d).methods.values() for s in (m.inter, m.intra))
    assert independent_check(d) == []
    res = verify_run(d, rel_tol=1e-6, pairs_file="pairs.csv.gz", tum_suffix=".gz")
    assert res.ok, res.differences[:5]
    assert any("independent scorer's figures were compared without them" in n for n in res.notes), res.notes


def _overlay(base: object, new: object) -> object:
    if isinstance(base, dict) and isinstance(new, dict):
        return {**base, **{k: _overlay(base.get(k), v) for k, v in new.items()}}
    return new


@needs_reference
def test_every_claim_follows_from_the_independent_figures():
    from roman_sim.evaluation.run_summary import RunSummary
    from roman_sim.studies.claims import SweepRow, claims

    summary = _summary()
    runs = {
        name: from_json(RunSummary, _overlay(copy.deepcopy(run), S.score_run(REF / name)), "test")
        for name, run in summary["runs"].items()
    }
    rows = S.sweep_rows(REF / "ambiguity_sweep") if (REF / "ambiguity_sweep").is_dir() else []
    again = claims(runs, [from_json(SweepRow, r, "sweep row") for r in rows])
    assert [(c.id, c.holds, c.text) for c in again] == [(c["id"], c["holds"], c["text"]) for c in summary["claims"]]


@needs_reference
def test_the_ambiguity_sweep_rows_follow_from_the_independent_scorer():
    if not (REF / "ambiguity_sweep" / "sweep.json").is_file():
        pytest.skip("no committed ambiguity sweep")
    diffs = S.agreement(_summary()["ambiguity_sweep"], S.sweep_rows(REF / "ambiguity_sweep"))
    assert not diffs, diffs[:10]
