"""The committed attribution study: its table re-derived from the kept raw pairs by the independent
scorer, and the heading-mechanisms page's block (figures and classes) made from that table."""

from __future__ import annotations

from pathlib import Path

import pytest
from committed_results import ATTRIBUTION as KEPT

from roman_sim.core.records import from_json
from roman_sim.studies import independent_scorer as S
from roman_sim.studies.attribution import FIELDS, MARKERS, PAGE, AttributionRow, attribution_block, classify, read_table
from roman_sim.studies.pages import current_block

ROOT = Path(__file__).parents[2]

pytestmark = pytest.mark.skipif(not (KEPT / "attribution.csv").is_file(), reason="no committed attribution study")


def _rows(derived: list[dict]) -> list[AttributionRow]:
    """The independent scorer's rows (plain dicts: it shares no code with the study) as table rows."""
    return [from_json(AttributionRow, r, "the independent scorer's row") for r in derived]


def test_the_independent_scorer_rederives_the_committed_table() -> None:
    table = read_table(KEPT)
    derived = S.attribution_rows(KEPT)
    assert [(r.mechanism, r.method) for r in table] == [(r["mechanism"], r["method"]) for r in derived]
    for t, d in zip(table, derived):
        for k in FIELDS:
            if d[k] is None or isinstance(d[k], str):
                assert getattr(t, k) == d[k], k
            else:
                assert getattr(t, k) == pytest.approx(d[k], abs=1e-6), (t.mechanism, t.method, k)


def test_the_page_block_is_the_committed_tables() -> None:
    page = (ROOT / PAGE).read_text(encoding="utf-8")
    assert current_block(page, MARKERS) == attribution_block(KEPT)


def test_the_classes_on_the_page_follow_the_independently_derived_shares() -> None:
    derived = S.attribution_rows(KEPT)
    page = current_block((ROOT / PAGE).read_text(encoding="utf-8"), MARKERS) or ""
    for method in dict.fromkeys(str(r["method"]) for r in derived):
        classes = classify(_rows(derived), method)  # the scorer's rows, not the table's
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


def _page() -> str:
    return " ".join((ROOT / PAGE).read_text(encoding="utf-8").split())


def test_the_page_states_the_kept_runs_sizes_and_times() -> None:
    """The sizes paragraph: relevant pairs per run and pooled, interval widths, the timed runs' total and range."""
    import json

    spec = json.loads((KEPT / "attribution.json").read_text())
    assert spec["config"]["seeds"] == [0, 1, 2, 3] and len(spec["runs"]) == 40
    table = read_table(KEPT)
    assert {r.worlds for r in table} == {4}
    pooled = {getattr(r, f"{role}_relevant") for r in table for role in ("same", "opposite")}
    assert pooled == {124, 132, 134}
    assert {r.same_relevant for r in table if r.mechanism == "road_side"} == {132}
    assert {r.opposite_relevant for r in table if r.mechanism == "road_side"} == {134}
    every_run = _relevant_per_run()
    others = [n for mech, n in every_run if mech != "road_side"]
    assert min(others) == 30 and max(others) == 32
    assert min(n for _, n in every_run) == 30 and max(n for _, n in every_run) == 34
    ci = [
        (getattr(r, f"{role}_recall_lo"), getattr(r, f"{role}_recall_hi"))
        for r in table
        for role in ("same", "opposite")
    ]
    halves = [(hi - lo) / 2 for lo, hi in ci]
    assert round(min(halves), 2) == 0.04 and round(max(halves), 2) == 0.09
    drops = [(r.drop_hi - r.drop_lo) / 2 for r in table]
    assert round(min(drops), 2) == 0.07 and round(max(drops), 2) == 0.11
    boots = [(r.drop_worlds_hi - r.drop_worlds_lo) / 2 for r in table]
    assert round(min(boots), 2) == 0.02 and round(max(boots), 2) == 0.18
    runs = sorted((KEPT / "runs").iterdir())
    timed = {p.name: t for p in runs if (t := _stage_seconds(p)) is not None}
    assert len(timed) == 40 and round(sum(timed.values())) == 2618
    assert round(min(timed.values())) == 12 and round(max(timed.values())) == 588
    page = _page()
    stated = (
        "the forty runs of the committed study (four worlds) took 2618 s of stage time together, ",
        "between 12 s and 588 s a run",
        "(30 to 32 per run, up to 34 with `road_side` off), 124 per direction pooled over the four worlds",
        "(132 and 134 with `road_side` off)",
        "Wilson intervals of +-0.04 to +-0.09 on each pooled recall",
        "Newcombe intervals of +-0.07 to +-0.11 on each pooled drop",
        "world-bootstrap intervals of +-0.02 to +-0.18",
    )
    assert [x for x in stated if x not in page] == []


def _relevant_per_run() -> list[tuple[str, int]]:
    """Every kept run's mechanism and relevant cross-robot pairs (ROMAN's rows), from the raw pairs."""
    import json

    spec = json.loads((KEPT / "attribution.json").read_text())
    out = []
    for run in spec["runs"]:
        cfg, pairs, judged = S.judged_rows(KEPT / "runs" / run["run"])
        n = sum(j.relevant for p, j in zip(pairs, judged) if p.method == "roman" and p.kind == "inter")
        out.append((run["mechanism"], n))
    return out


def _world_counts() -> dict[int, tuple[int, int, int, int]]:
    """ROMAN's all-on (same hits, same relevant, opposite hits, opposite relevant) per world seed, from raw pairs."""
    import json

    spec = json.loads((KEPT / "attribution.json").read_text())
    got: dict[int, dict[str, tuple[int, int]]] = {}
    for run in spec["runs"]:
        if run["mechanism"] != "none":
            continue
        cfg, pairs, judged = S.judged_rows(KEPT / "runs" / run["run"])
        rows = [j for p, j in zip(pairs, judged) if p.method == "roman" and p.kind == "inter"]
        pt = S.operating_points(rows, cfg)["max_recall"]
        assert isinstance(pt, dict)
        got.setdefault(run["seed"], {})[run["role"]] = (int(pt["hits"]), int(pt["n_relevant"]))
    return {w: (*v["same"], *v["opposite"]) for w, v in got.items()}


def test_the_measured_paragraph_is_the_independently_derived_table() -> None:
    """Every figure and claim of the paragraph under the block, from the scorer's rows and raw pairs."""
    rows = {(r["mechanism"], r["method"]): r for r in S.attribution_rows(KEPT)}
    page = _page()
    f = lambda x: f"{x:+.2f}"  # noqa: E731
    for method, name in (("roman", "ROMAN"), ("ransac1m", "RANSAC-1M")):
        r = rows[("none", method)]
        assert r["drop_worlds_lo"] > 0 and r["drop_lo"] > 0  # separated from 0 by both intervals
        claim = (
            f"{name}'s {'max recall falls ' if method == 'roman' else ''}from {r['same_recall']:.2f} to "
            f"{r['opposite_recall']:.2f} ({f(r['drop'])}, "
        )
        assert claim in page, claim
        boot = f"[{f(r['drop_worlds_lo'])}, {f(r['drop_worlds_hi'])}]"
        assert f"{f(r['drop'])}, {'world bootstrap ' if method == 'roman' else ''}{boot})" in page
        # the world bootstrap is wider than Newcombe's for the all-on drop, narrower with partial views off
        assert r["drop_worlds_hi"] - r["drop_worlds_lo"] > r["drop_hi"] - r["drop_lo"]
        p = rows[("partial_views", method)]
        assert p["drop_worlds_hi"] - p["drop_worlds_lo"] < p["drop_hi"] - p["drop_lo"]
        assert f(p["drop"]) == "+0.03" and 0.85 < p["explained"] < 0.95  # "+0.03 ... about 90 %"
        assert classify(_rows(list(rows.values())), method)["dominant"] == ["partial_views"]
        assert classify(_rows(list(rows.values())), method)["negligible"] == [
            "descriptor_view",
            "lighting",
            "road_side",
        ]
    assert "the drop shrinks to +0.03 for both methods, about 90 % of it" in page
    d = rows[("descriptor_view", "roman")]
    assert d["drop_worlds_lo"] > 0
    boot = f"[{f(d['drop_worlds_lo'])}, {f(d['drop_worlds_hi'])}]"
    assert f"ROMAN's drop is {f(d['drop'])} (world bootstrap {boot}) and does not vanish" in page
    road = rows[("road_side", "roman")]
    assert 0 < road["explained"] < 0.2 and f"The road side's share for ROMAN, {100 * road['explained']:.0f} %" in page
    worlds = _world_counts()
    assert sorted(worlds) == [0, 1, 2, 3]
    per_world = [hs / ns - ho / no for hs, ns, ho, no in (worlds[w] for w in sorted(worlds))]
    stated = ", ".join(f(x) for x in per_world[:-1]) + f" and {f(per_world[-1])}"
    assert f"ROMAN's all-on drop is {stated} in worlds 0 to 3" in page
    assert len(set(round(x, 2) for x in per_world)) == 4  # the worlds disagree
