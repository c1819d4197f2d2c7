"""The committed reference results: every number and claim follows from their raw data.

Driven by ``results/reference/summary.json`` (whatever scenarios and claims it holds, so a
later regeneration needs no change here): each run's ``metrics.json`` and ``ate.json`` are
recomputed from its compressed pairs table and trajectories; the whole summary is re-derived
from the raw files; ``summary.md`` must be exactly what that summary renders to (the pages
rendered from it are checked in ``tests/test_docs_results.py``). A claim that does not hold on
the data cannot be listed as holding.
"""

from __future__ import annotations

import json

import pytest
from committed_results import REFERENCE as REF
from committed_results import committed_files

from roman_sim.core.records import to_json
from roman_sim.report.recompute import compare
from roman_sim.studies.reference import read_reference, rederive, reference_markdown
from roman_sim.studies.verify import verify_run

#: Committed reference results (raw data included) must stay small enough for a repository:
#: about 31 MB for the small scenarios, the demo, the paper preset (13 runs) and the sweep, and
#: 10-13 MB per paper-scale run, three of them (trajectories at frame rate, the pairs table and
#: the submap packets the independent scorer reads): 67.0 MB committed.
MAX_REFERENCE_MB = 70.0

pytestmark = pytest.mark.skipif(not (REF / "summary.json").is_file(), reason="no committed reference results")


def _summary() -> dict:
    return json.loads((REF / "summary.json").read_text(encoding="utf-8"))


def _scenarios() -> list[str]:
    return sorted(_summary()["runs"]) if (REF / "summary.json").is_file() else []


@pytest.mark.parametrize("scenario", _scenarios())
def test_each_reference_run_recomputes_from_its_raw_data(scenario):
    res = verify_run(REF / scenario, rel_tol=1e-6, pairs_file="pairs.csv.gz", tum_suffix=".gz")
    assert res.ok, res.differences[:10]
    assert len(res.checked) == (3 if (REF / scenario / "ate.json").is_file() else 2)


def test_summary_follows_from_the_raw_files():
    committed = _summary()
    again = json.loads(json.dumps(to_json(rederive(REF)), sort_keys=True))
    diffs = compare(committed, again, "summary.json", rel_tol=1e-6, abs_tol=1e-9)
    assert not diffs, diffs[:10]


def test_claims_are_listed_as_the_data_says():
    summary = read_reference(REF / "summary.json")
    assert summary.claims, "the reference summary states no claim"
    text = reference_markdown(summary)
    held, failed = text.split("Where it does not:")
    for c in summary.claims:
        assert c.text in (held if c.holds else failed), c.id


def test_summary_md_is_rendered_from_the_summary():
    assert (REF / "summary.md").read_text(encoding="utf-8") == reference_markdown(read_reference(REF / "summary.json"))


def test_reference_results_keep_raw_data_and_stay_small():
    total = sum(p.stat().st_size for p in committed_files(roots=[REF]))
    assert total < MAX_REFERENCE_MB * 1e6, f"{total / 1e6:.1f} MB"
    for scenario in _scenarios():
        d = REF / scenario
        assert (d / "pairs.csv.gz").is_file() and (d / "alignments.json.gz").is_file()
        if (d / "ate.json").is_file():
            assert list((d / "trajectories").glob("*.truth.tum.gz"))
