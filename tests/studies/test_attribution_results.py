"""The committed attribution study: its table re-derived from the kept raw pairs by the independent
scorer, and the heading-mechanisms page's block (figures and classes) made from that table."""

from __future__ import annotations

from pathlib import Path

import pytest

from roman_sim.studies import independent_scorer as S
from roman_sim.studies.attribution import FIELDS, MARKERS, PAGE, attribution_block, classify, read_table
from roman_sim.studies.pages import current_block

ROOT = Path(__file__).parents[2]
KEPT = ROOT / "results" / "attribution"

pytestmark = pytest.mark.skipif(not (KEPT / "attribution.csv").is_file(), reason="no committed attribution study")


def test_the_independent_scorer_rederives_the_committed_table() -> None:
    table = read_table(KEPT)
    derived = S.attribution_rows(KEPT)
    assert [(r["mechanism"], r["method"]) for r in table] == [(r["mechanism"], r["method"]) for r in derived]
    for t, d in zip(table, derived):
        for k in FIELDS:
            if d[k] is None or isinstance(d[k], str):
                assert t[k] == d[k], k
            else:
                assert t[k] == pytest.approx(d[k], abs=1e-6), (t["mechanism"], t["method"], k)


def test_the_page_block_is_the_committed_tables() -> None:
    page = (ROOT / PAGE).read_text(encoding="utf-8")
    assert current_block(page, MARKERS) == attribution_block(KEPT)


def test_the_classes_on_the_page_follow_the_independently_derived_shares() -> None:
    derived = S.attribution_rows(KEPT)
    page = current_block((ROOT / PAGE).read_text(encoding="utf-8"), MARKERS) or ""
    for method in dict.fromkeys(str(r["method"]) for r in derived):
        classes = classify(derived, method)  # the scorer's rows, not the table's
        line = next(ln for ln in page.splitlines() if ln.startswith(f"- {method}: all-on drop"))
        for key, label in (("dominant", "Dominant"), ("contributes", "contributing"), ("negligible", "negligible")):
            part = line.split(f"{label} (", 1)[1].split(";", 1)[0].split(".", 1)[0]
            named = part.split(": ", 1)[1]
            assert named == (", ".join(f"`{m}`" for m in classes[key]) or "none"), (method, key)
