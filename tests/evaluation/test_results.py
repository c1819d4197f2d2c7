"""pairs.csv / metrics.json round trips and StorageError on missing or corrupt files."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from roman_sim.core.errors import StorageError
from roman_sim.core.records import to_json
from roman_sim.evaluation.config import EvalConfig
from roman_sim.evaluation.metrics import compute_metrics, score_pair
from roman_sim.evaluation.pairs import enumerate_pairs, pair_truth
from roman_sim.evaluation.results import (
    PAIRS_FIELDS,
    read_evaluation,
    read_metrics_json,
    read_pairs_csv,
    write_evaluation,
    write_pairs_csv,
)


@pytest.fixture
def scores(make_submap, result_for):
    subs = [make_submap("a", 0, 0, 0, 20.0), make_submap("a", 2, 4, 1, 170.0), make_submap("b", 0, 1, 2, -75.0)]
    out = []
    for a, b in enumerate_pairs(subs):
        t = pair_truth(a, b, ambiguity_fn=lambda xy: 0.3)
        out.append(score_pair(t, result_for(t.T_a_b_true, 5, "roman")))
        out.append(score_pair(t, result_for(None, 0, "ransac")))
    return out


def test_csv_round_trip_is_exact(scores, tmp_path):
    write_pairs_csv(tmp_path / "pairs.csv", scores)
    back = read_pairs_csv(tmp_path / "pairs.csv")
    assert len(back) == len(scores) == 6
    for s, r in zip(scores, back):
        np.testing.assert_allclose(r.truth.T_a_b_true, s.truth.T_a_b_true, atol=1e-12)
        for f in ("a", "b", "kind", "relevant", "center_dist_m", "heading_diff_deg", "overlap", "ambiguity"):
            assert getattr(r.truth, f) == getattr(s.truth, f), f
        assert (r.method, r.n_assoc, r.correct, r.reason) == (s.method, s.n_assoc, s.correct, s.reason)
        assert math.isnan(r.runtime_s)  # runtimes are kept in timings.json, not in pairs.csv
        assert math.isnan(r.rot_err_deg) == math.isnan(s.rot_err_deg)
    header = (tmp_path / "pairs.csv").read_text().splitlines()[0]
    assert header == ",".join(PAIRS_FIELDS)


def test_metrics_round_trip_and_nan_is_null(scores, tmp_path):
    m = compute_metrics(scores)
    paths = write_evaluation(tmp_path, scores, m)
    text = paths["metrics"].read_text()
    assert "NaN" not in text and "null" in text
    back_scores, back = read_evaluation(tmp_path)
    assert isinstance(back.config, EvalConfig) and back.config == m.config  # the settings, typed
    assert to_json(back) == json.loads(json.dumps(to_json(m)))
    assert to_json(compute_metrics(back_scores)) == to_json(back)


def test_missing_and_corrupt_files_raise_storage_error(scores, tmp_path):
    with pytest.raises(StorageError, match="cannot read"):
        read_pairs_csv(tmp_path / "nope.csv")
    with pytest.raises(StorageError, match="cannot read"):
        read_metrics_json(tmp_path / "nope.json")
    p = write_pairs_csv(tmp_path / "pairs.csv", scores)
    lines = p.read_text().splitlines()
    assert ",roman,5," in lines[1]
    p.write_text("\n".join([lines[0], lines[1].replace(",roman,5,", ",roman,many,")]) + "\n")
    with pytest.raises(StorageError, match="line 2"):
        read_pairs_csv(p)
    p.write_text("\n".join(lines[:2] + [lines[2][:20]]) + "\n")
    with pytest.raises(StorageError, match="cells"):
        read_pairs_csv(p)
    p.write_text("a,b\n1,2\n")
    with pytest.raises(StorageError, match="missing columns"):
        read_pairs_csv(p)
    j = tmp_path / "metrics.json"
    j.write_text('{"methods": {')
    with pytest.raises(StorageError, match="corrupt"):
        read_metrics_json(j)
    j.write_text('{"methods": {}}')
    with pytest.raises(StorageError, match="schema"):
        read_metrics_json(j)


def test_numpy_scalars_are_written_as_plain_numbers(scores, tmp_path):
    s = scores[0]
    t = type(s.truth)(
        **{**s.truth.__dict__, "center_dist_m": np.float64(2.5), "relevant": np.bool_(True), "index_b": np.int64(7)}
    )
    p = write_pairs_csv(tmp_path / "pairs.csv", [type(s)(**{**s.__dict__, "truth": t})])
    assert "np." not in p.read_text()
    back = read_pairs_csv(p)[0].truth
    assert (back.center_dist_m, back.relevant, back.index_b) == (2.5, True, 7)
