"""The committed fit of the ``paper`` front-end preset and its held-out predictions follow from their raw pairs.

Every figure of ``results/reference/paper_preset`` (each fit run's ROMAN hits and relevant
pairs, the admitted severities, each prediction run's ROMAN, RANSAC-1M and CLIPPER max recall,
each claim's values, range and verdict) is recomputed by the independent scorer from the kept
``pairs.csv.gz`` and ``alignments.json.gz``, and the predictions are checked here by hand
against the paper's figures; the results page's block is what the committed files render to.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from committed_results import ATTRIBUTION, REFERENCE

from roman_sim.core.records import from_json
from roman_sim.studies import independent_scorer as S
from roman_sim.studies.attribution import AttributionRow, drop_interval
from roman_sim.studies.pages import current_block
from roman_sim.studies.paper_preset import PRESET_MARKERS, preset_block

ROOT = Path(__file__).resolve().parents[2]
FOLDER = REFERENCE / "paper_preset"

pytestmark = pytest.mark.skipif(
    not (FOLDER / "paper_fit.yaml").is_file(), reason="no committed fit of the paper front-end preset"
)


def _max_recall(run: Path, method: str) -> float | None:
    return S.score_run(run)["methods"][method]["inter"]["max_recall"]  # type: ignore[index]


def _fit() -> dict:
    return yaml.safe_load((FOLDER / "paper_fit.yaml").read_text(encoding="utf-8"))["fit"]


def _predictions() -> dict:
    return json.loads((FOLDER / "paper_predictions.json").read_text(encoding="utf-8"))


def _scored() -> dict:
    return S.paper_preset_figures(FOLDER)


def test_every_fit_run_is_committed_and_its_recall_follows_from_its_pairs():
    fit, scored = _fit(), _scored()
    assert fit["paper"] == 0.67 and fit["figure"].startswith("roman max recall")
    assert len(fit["searched"]) >= 2
    assert sorted(scored["fit"]) == [s for s, _ in fit["searched"]]  # a run folder per run, no other
    for severity, recall in fit["searched"]:
        run = FOLDER / "runs" / f"{fit['config']['scenario']}_{severity:.6f}"
        assert run.is_dir(), run
        assert _max_recall(run, "roman") == pytest.approx(recall, rel=1e-12), severity
    for r in fit["runs"]:
        got = scored["fit"][r["severity"]]
        assert (r["hits"], r["relevant"]) == (got["hits"], got["relevant"]), r["severity"]
        assert r["ci"] == pytest.approx(got["ci"], abs=1e-9)
    best = min(fit["searched"], key=lambda sr: (abs(sr[1] - 0.67), sr[0]))
    assert [fit["severity"], fit["fitted"]] == best  # the run closest to the paper, as measured
    assert scored["fitted"] == fit["severity"]


def test_the_admitted_settings_follow_from_the_pairs():
    fit, pred, scored = _fit(), _predictions(), _scored()
    assert fit["admitted"] == pred["admitted"]["severities"] == scored["admitted"]
    for r in fit["runs"]:
        lo, hi = scored["fit"][r["severity"]]["ci"]
        assert r["admitted"] == (lo <= 0.67 <= hi or r["severity"] == fit["severity"]), r["severity"]
    assert fit["severity"] in fit["admitted"]


def test_the_predictions_follow_from_the_prediction_runs_and_are_judged_by_hand():
    pred, scored = _predictions(), _scored()
    assert [st["severity"] for st in pred["settings"]] == scored["admitted"]
    for st in pred["settings"]:
        s = st["severity"]
        if st["run"] is None:
            assert s not in scored["predicted"], s  # marked not run: no run folder for it
            assert all(c["settings"][pred["settings"].index(st)]["value"] is None for c in pred["claims"])
            continue
        run = FOLDER / st["run"]
        got = {m: _max_recall(run, m) for m in ("roman", "ransac1m", "clipper")}
        for m, v in got.items():
            assert st["max_recall"][m]["max_recall"] == pytest.approx(v, rel=1e-12), (s, m)
            assert st["max_recall"][m]["hits"] == scored["predicted"][s][m]["hits"], (s, m)
        roman, ransac, clipper = got["roman"], got["ransac1m"], got["clipper"]
        same = scored["fit"][s]["hits"] / scored["fit"][s]["relevant"]
        i = pred["settings"].index(st)
        holds = [c["settings"][i]["holds"] for c in pred["claims"]]
        assert holds[0] == (0.18 <= roman <= 0.34)  # the paper's 0.26 +- 0.08
        assert holds[1] == (roman > ransac > clipper)  # the paper's ordering
        ratio = same / roman if roman else None
        assert holds[2] == (ratio is not None and 0.67 / 0.34 <= ratio <= 0.67 / 0.18)  # the paper's 2.6
    for claim, name in zip(pred["claims"], ("opposite", "ordering", "ratio")):
        mine = scored["claims"][name]
        assert claim["verdict"] == mine["verdict"], name
        if isinstance(mine["range"], dict):
            for m, span in mine["range"].items():
                assert claim["range"][m] == pytest.approx(span, rel=1e-12), (name, m)
        else:
            assert claim["range"] == pytest.approx(mine["range"], rel=1e-12), name
        assert claim["holds_for"] == [s for s, h in mine["holds"].items() if h], name
        assert claim["not_run"] == [s for s, v in mine["values"].items() if v is None], name


def test_the_results_page_block_is_the_committed_fit():
    page = (ROOT / "docs" / "results.md").read_text(encoding="utf-8")
    assert current_block(page, PRESET_MARKERS) == preset_block(FOLDER)


def _revisit(run: Path) -> tuple[int, float, float]:
    """Relevant cross-robot pairs, their median overlap and median shared objects (pairs.csv.gz)."""
    import csv
    import gzip
    import statistics

    with gzip.open(run / "pairs.csv.gz", "rt", encoding="utf-8") as f:
        rows = [
            r
            for r in csv.DictReader(f)
            if r["method"] == "roman" and r["robot_a"] != r["robot_b"] and r["relevant"] == "true"
        ]
    return (
        len(rows),
        float(statistics.median(float(r["overlap"]) for r in rows)),
        float(statistics.median(int(r["shared_objects"]) for r in rows)),
    )


def _span(values: list[float], digits: int = 2) -> str:
    lo, hi = round(min(values), digits), round(max(values), digits)
    return f"{lo:.{digits}f}" if lo == hi else f"{lo:.{digits}f}-{hi:.{digits}f}"


def _int_span(values: list[float]) -> str:
    lo, hi = int(min(values)), int(max(values))
    return str(lo) if lo == hi else f"{lo}-{hi}"


def test_the_explained_miss_follows_from_the_runs():
    """The miss paragraph's ranges, verdict wording and overlaps follow from the committed runs."""
    import re

    page = " ".join((ROOT / "docs" / "results.md").read_text(encoding="utf-8").split())
    fit, pred = _fit(), _predictions()
    settings = [st for st in pred["settings"] if st["run"]]
    assert [st["severity"] for st in settings] == fit["admitted"], "every admitted setting has its run"
    same = {r["severity"]: r["hits"] / r["relevant"] for r in fit["runs"]}
    opp = {st["severity"]: st["max_recall"]["roman"]["max_recall"] for st in settings}
    ratio = {s: same[s] / opp[s] for s in opp}
    m = re.search(
        r"\*\*The `paper` preset predicts too much opposite-direction recall\*\* \(([\d.-]+) against the "
        r"paper's 0\.26 at every admitted setting\) and a same/opposite ratio inside the paper's 1\.97-3\.72 at "
        r"one admitted setting only \(([\d.-]+) against 2\.6\), though it gets the ordering ROMAN > RANSAC-1M > "
        r"CLIPPER right at every admitted setting",
        page,
    )
    assert m, "docs/results.md explains the preset's miss"
    assert [m[1], m[2]] == [_span(list(opp.values())), _span(list(ratio.values()))]
    assert not any(0.18 <= v <= 0.34 for v in opp.values()), "no admitted setting reaches the paper's 0.26"
    inside = [s for s, r in ratio.items() if 0.67 / 0.34 <= r <= 0.67 / 0.18]
    assert inside == [min(ratio)], "one setting only: the lowest admitted severity"
    assert max(same[s] for s in opp) == same[min(opp)], "whose same-direction recall is the highest"
    for st in settings:
        rec = {k: v["max_recall"] for k, v in st["max_recall"].items()}
        assert rec["roman"] > rec["ransac1m"] > rec["clipper"], st["severity"]
    m = re.search(
        r"share a median overlap of ([\d.-]+) and ([\d-]+) objects \((\d+) pairs\), against ([\d.-]+) and "
        r"([\d-]+) objects \((\d+) pairs\) in the same-direction runs",
        page,
    )
    assert m, "docs/results.md states the runs' overlap"
    o = [_revisit(FOLDER / st["run"]) for st in settings]
    d = [_revisit(FOLDER / "runs" / f"{fit['config']['scenario']}_{s:.6f}") for s in opp]
    assert {n for n, _, _ in o} == {int(m[3])} and {n for n, _, _ in d} == {int(m[6])}
    assert [m[1], m[2]] == [_span([v for _, v, _ in o]), _int_span([k for _, _, k in o])]
    assert [m[4], m[5]] == [_span([v for _, v, _ in d]), _int_span([k for _, _, k in d])]


def test_the_committed_runs_front_end_is_the_current_one():
    """Every committed run sets the paper preset at its severity, with the per-family view dependence
    and the light-versus-view term switched on, as the page says."""
    page = " ".join((ROOT / "docs" / "results.md").read_text(encoding="utf-8").split())
    assert (
        "each run's configuration (`config.yaml`) sets the `paper` preset and its severity, and the semantics' "
        "per-family view dependence and light-versus-view term (`frontend.semantics.view_dependence` and "
        "`lighting` on)" in page
    )
    runs = sorted((FOLDER / "runs").iterdir())
    assert len(runs) == len(_fit()["searched"]) + len(_fit()["admitted"])
    for run in runs:
        fe = yaml.safe_load((run / "config.yaml").read_text(encoding="utf-8"))["frontend"]
        assert fe["preset"] == "paper", run.name
        assert f"{fe['severity']:.6f}" == run.name.rsplit("_", 1)[1], run.name
        sem = fe["semantics"]
        assert sem["view_dependence"] is True and sem["lighting"] is True, run.name
        assert "appearance" in sem, run.name


def test_the_stated_cost_follows_from_the_runs_timings():
    import re

    page = " ".join((ROOT / "docs" / "results.md").read_text(encoding="utf-8").split())
    m = re.search(
        r"the committed (\d+) runs took (\d+) min of stage time together \((\d+) to (\d+) min a run, from their "
        r"`timings\.json`.* \((\d+) runs here\) and then one opposite-direction run per admitted severity "
        r"\((\d+) here\)",
        page,
    )
    assert m, "docs/results.md states the re-fit's cost"
    secs = [
        sum(v["seconds"] for v in json.loads((run / "timings.json").read_text())["stages"].values())
        for run in sorted((FOLDER / "runs").iterdir())
    ]
    assert int(m[1]) == len(secs) == int(m[5]) + int(m[6])
    assert [int(m[2]), int(m[3]), int(m[4])] == [round(sum(secs) / 60), round(min(secs) / 60), round(max(secs) / 60)]
    assert [int(m[5]), int(m[6])] == [len(_fit()["searched"]), len(_fit()["admitted"])]


def test_the_mechanisms_cited_for_the_miss_are_the_attribution_studys():
    """Partial views dominant for ROMAN, descriptor view dependence negligible, all-on drop separated from 0."""
    page = " ".join((ROOT / "docs" / "results.md").read_text(encoding="utf-8").split())
    assert (
        "on shrunk scenarios in four worlds, finds partial views the dominant mechanism of ROMAN's drop and "
        "the descriptor's view dependence negligible, with an all-on drop whose world-bootstrap interval "
        "excludes 0" in page
    )
    rows = {(r["mechanism"], r["method"]): r for r in S.attribution_rows(ATTRIBUTION)}
    assert rows[("partial_views", "roman")]["explained"] >= 0.5
    assert rows[("descriptor_view", "roman")]["explained"] < 0.2
    assert (
        max(r["explained"] for (mech, m), r in rows.items() if m == "roman" and mech != "none")
        == (rows[("partial_views", "roman")]["explained"])
    )
    assert {r["worlds"] for r in rows.values()} == {4}
    row = from_json(AttributionRow, rows[("none", "roman")], "the independent scorer's row")
    lo, _, kind = drop_interval(row) or (0.0, 0.0, "")  # the interval the verdict uses
    assert kind == "world-bootstrap" and lo > 0


def test_the_scorer_and_the_study_agree_where_the_admitted_settings_disagree(tmp_path):
    """A copy of the committed fit whose prediction run at severity 2 is replaced by the same-direction
    run at 2 (which lacks RANSAC-1M and CLIPPER, so the ordering fails there and holds at the other
    admitted settings): the verdicts read 'none', 'some' and 'none', alike from the study's figures
    (each run's metrics) and from the scorer's (raw pairs)."""
    import shutil

    from roman_sim.studies.paper_preset import predict_paper_preset

    for name in ("paper_fit.yaml", "paper_predictions.json"):
        shutil.copyfile(FOLDER / name, tmp_path / name)
    state = json.loads((FOLDER / "fit_state.json").read_text(encoding="utf-8"))
    del state["predicted"]["2.000000"]  # no counts for it: the study measures the swapped run
    (tmp_path / "fit_state.json").write_text(json.dumps(state, indent=2), encoding="utf-8")
    (tmp_path / "runs").mkdir()
    for run in (FOLDER / "runs").iterdir():
        source = FOLDER / "runs" / "same_direction_2.000000" if run.name == "opposite_direction_2.000000" else run
        (tmp_path / "runs" / run.name).symlink_to(source)
    called: list[Path] = []

    def from_metrics(scenario, overrides, run_dir):
        called.append(run_dir)
        inter = {m: v["inter"] for m, v in json.loads((run_dir / "metrics.json").read_text())["methods"].items()}
        return {
            m: (inter[m]["max_hits"], inter[m]["n_relevant"]) if m in inter else (0, 0)
            for m in ("roman", "ransac1m", "clipper")
        }

    pred = predict_paper_preset(tmp_path, run=from_metrics)
    assert [p.name for p in called] == ["opposite_direction_2.000000"]
    scored = S.paper_preset_figures(tmp_path)
    assert [c.verdict for c in pred.claims] == [
        scored["claims"][n]["verdict"] for n in ("opposite", "ordering", "ratio")
    ]
    assert [c.verdict for c in pred.claims] == ["none", "some", "none"]
    assert pred.claims[1].holds_for == [2.25, 2.375, 2.5] and pred.claims[1].fails_for == [2.0]
    for claim, name in zip(pred.claims, ("opposite", "ordering", "ratio")):
        assert claim.holds_for == [s for s, h in scored["claims"][name]["holds"].items() if h], name
        if name != "ordering":
            assert claim.range == pytest.approx(scored["claims"][name]["range"], rel=1e-12), name
