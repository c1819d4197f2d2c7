"""The independent scorer: its definitions by hand, and its agreement with every committed run.

The scorer (``roman_sim.studies.scorer``) shares no code with the evaluation that produced the
committed figures; these tests check it first on inputs whose answers are worked out by hand,
then re-derive every committed run's summary figures and every claim from the raw files.
"""

from __future__ import annotations

import copy
import csv
import gzip
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from roman_sim.studies import scorer as S

ROOT = Path(__file__).resolve().parents[2]
REF = ROOT / "results" / "reference"
CFG = S.Settings("distance", 10.0, 3, 5.0, 1.0, 0, 30, (0.0, 60.0, 120.0, 180.0), 5, 0.95)


def test_the_scorer_imports_no_scoring_code():
    import grimp

    graph = grimp.build_graph("roman_sim")
    imported = graph.find_upstream_modules("roman_sim.studies.scorer")  # everything it imports, transitively
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


def test_umeyama_recovers_a_rigid_transform():
    rng = np.random.default_rng(3)
    est = rng.normal(size=(50, 3))
    R = S.pose_4dof(0.0, 0.0, 0.0, 1.1)[:3, :3]
    ref = est @ R.T + np.array([4.0, -2.0, 1.0])
    assert np.max(S.umeyama_residuals(est, ref)) < 1e-9
    noisy = ref + rng.normal(scale=0.1, size=ref.shape)
    # 0.1 m per axis: about 0.1 * sqrt(3) m in 3D, a little less after the fit absorbs 6 degrees of freedom
    assert np.sqrt(np.mean(S.umeyama_residuals(est, noisy) ** 2)) < 0.1 * math.sqrt(3)


def _write_run(d: Path, rows: list[dict[str, object]], estimates: list[dict[str, object]]) -> None:
    d.mkdir(parents=True)
    (d / "config.yaml").write_text(
        "evaluation:\n  relevance: distance\n  relevant_dist_m: 10.0\n  min_shared_objects: 3\n"
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


def _overlay(base: object, new: object) -> object:
    if isinstance(base, dict) and isinstance(new, dict):
        return {**base, **{k: _overlay(base.get(k), v) for k, v in new.items()}}
    return new


@needs_reference
def test_every_claim_follows_from_the_independent_figures():
    from roman_sim.report.summaries import RunSummary
    from roman_sim.studies.claims import claims

    summary = _summary()
    runs = {
        name: RunSummary.from_json(_overlay(copy.deepcopy(run), S.score_run(REF / name)))
        for name, run in summary["runs"].items()
    }
    sweep = S.sweep_rows(REF / "ambiguity_sweep") if (REF / "ambiguity_sweep").is_dir() else []
    again = claims(runs, sweep)
    assert [(c["id"], c["holds"], c["text"]) for c in again] == [
        (c["id"], c["holds"], c["text"]) for c in summary["claims"]
    ]


@needs_reference
def test_the_ambiguity_sweep_rows_follow_from_the_independent_scorer():
    if not (REF / "ambiguity_sweep" / "sweep.json").is_file():
        pytest.skip("no committed ambiguity sweep")
    diffs = S.agreement(_summary()["ambiguity_sweep"], S.sweep_rows(REF / "ambiguity_sweep"))
    assert not diffs, diffs[:10]
