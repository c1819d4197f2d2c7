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


def _stage_seconds(run: Path) -> float | None:
    """A kept run's stage time (s), None when a stage was reused from elsewhere (not timed here)."""
    import json

    stages = json.loads((run / "timings.json").read_text())["stages"]
    if any(v.get("reused") for v in stages.values()):
        return None
    return float(sum(v["seconds"] for v in stages.values()))


def test_the_page_states_the_kept_runs_sizes_and_times() -> None:
    """The sizes paragraph: relevant pairs per run, the timed runs' total and range, the slowest."""
    table = read_table(KEPT)
    assert {r[f"{role}_relevant"] for r in table for role in ("same", "opposite")} == {31, 32}
    halves = [(r["same_recall_hi"] - r["same_recall_lo"]) / 2 for r in table]
    assert 0.05 < min(halves) and max(halves) < 0.2
    drops = [(r["drop_hi"] - r["drop_lo"]) / 2 for r in table]
    assert 0.14 < min(drops) and max(drops) < 0.21
    runs = sorted((KEPT / "runs").iterdir())
    timed = {p.name: t for p in runs if (t := _stage_seconds(p)) is not None}
    assert len(timed) == 10 and round(sum(timed.values())) == 1544
    assert all(60 <= t <= 300 for t in timed.values())
    page = (ROOT / PAGE).read_text(encoding="utf-8")
    assert "took 1544 s of stage time" in " ".join(page.split())
