"""Planned pairs carry their place's ambiguity exactly as the rendered run scores it."""

from __future__ import annotations

import csv
import gzip
import math

from roman_sim.benchmark.scenes import build_crossing
from roman_sim.benchmark.suites import LEVELS, SUITES
from tests.committed_results import STANDARD


def test_a_planned_level_has_the_ambiguity_its_rendered_pairs_were_scored_with() -> None:
    """The standard board's medium world at seed 0, planned without rendering: every cross-robot pair's
    ambiguity equals the one its committed ``pairs.csv`` holds (the evaluation stage's, on the rendered run)."""
    scene = SUITES.get("standard").scene.model_copy(update={"ambiguity": LEVELS["medium"]})
    plan = build_crossing(scene, 0, name="medium-s0", ambiguity=True)
    planned = {(t.a, t.b): t.ambiguity for t in plan.truths if t.kind == "inter"}
    with gzip.open(STANDARD / "cells" / "medium-s0" / "pairs.csv.gz", "rt", newline="") as f:
        scored = {(r["a"], r["b"]): float(r["ambiguity"]) for r in csv.DictReader(f) if r["kind"] == "inter"}
    assert len(planned) == len(scored) == 665
    assert planned.keys() == scored.keys()
    assert all(abs(planned[k] - scored[k]) <= 1e-12 for k in planned)
    assert 0.4 < sum(scored.values()) / len(scored) < 0.5  # the medium level's index, about 0.45


def test_without_ambiguity_the_plan_leaves_it_unknown() -> None:
    scene = SUITES.get("quick").scene
    plan = build_crossing(scene, 0)
    assert plan.truths and all(math.isnan(t.ambiguity) for t in plan.truths)
