"""Hand-made run summaries for the claims and tables of the paper reproduction."""

from __future__ import annotations

import pytest


@pytest.fixture
def as_summaries():
    """``as_summaries(runs)``: hand-made JSON run summaries as ``RunSummary`` objects.

    Fields a test leaves out (the ones its claims and tables do not read) get neutral values.
    """
    from roman_sim.core.records import from_json
    from roman_sim.evaluation.run_summary import RunSummary

    set_defaults = {
        "n_pairs": 0,
        "recall_at_precision_1": None,
        "hits_at_precision_1": 0,
        "best_f1": None,
        "auc": None,
        "assoc_precision": None,
        "assoc_recall": None,
    }
    run_defaults = {
        "headline": "inter",
        "pairs": {},
        "n_skipped": 0,
        "methods": {},
        "ate": {},
        "ate_robots": {},
        "map": {},
        "frontend": None,
    }

    def convert(runs: dict) -> dict[str, RunSummary]:
        out = {}
        for name, run in runs.items():
            methods = {
                m: {k: {**set_defaults, **v} if k in ("inter", "intra") else v for k, v in entry.items()}
                for m, entry in run.get("methods", {}).items()
            }
            out[name] = from_json(RunSummary, {**run_defaults, **run, "methods": methods}, name)
        return out

    return convert
