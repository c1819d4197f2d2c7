"""``roman-sim tune`` end to end on a tiny suite: figures against the raw pairs, the recommended YAML,
resume (nothing re-run; a new alignment re-aligns without re-mapping), a bad parameter on a finished folder,
one level of a suite (its worlds only; a bad level; another level on the same folder)."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy import stats
from typer.testing import CliRunner

from roman_sim.align.aligners import RomanAligner, RomanParams
from roman_sim.benchmark.tune_result import read_tune, write_tune
from roman_sim.benchmark.tune_space import Config
from roman_sim.cli import app
from roman_sim.core.records import RecordError
from roman_sim.pipeline.scenario import load_scenario

pytestmark = pytest.mark.slow

SUITE = """\
name: tiny
description: two tiny crossing worlds
scene: {robots: 3, length_m: 24.0, site_radius_m: 2.0, extent_m: 40.0, render_rgb: false,
        image_width: 160, image_height: 120}
levels: {distinct: 0.0}
seeds: [0, 1]
methods: [roman]
"""
#: Two levels, one seed: ``--level distinct --seeds 0:2`` gives the worlds of ``SUITE``.
LEVELLED = SUITE.replace("levels: {distinct: 0.0}", "levels: {distinct: 0.0, twin: 1.0}").replace(
    "seeds: [0, 1]", "seeds: [0]"
)
KS = range(1, 9)


def _tune(home: Path, *params: str) -> tuple[int, str]:
    args = ["tune", str(home / "tiny.yaml"), "--out", str(home / "t"), "--param", "threshold=1:8", "--rule", "point"]
    for p in params:
        args += ["--param", p]
    res = CliRunner().invoke(app, args)
    return res.exit_code, res.output


def _by_hand(home: Path) -> dict[tuple[str, str], list[tuple[bool, bool, int]]]:
    """(world, alignment folder) -> (relevant, correct, associations) of each cross-robot pair, from pairs.csv."""
    out = {}
    for csv_path in sorted((home / "t" / "work").glob("*/*/run/pairs.csv")):
        align, world = csv_path.parents[1].name, csv_path.parents[2].name
        with csv_path.open() as fh:
            rows = [r for r in csv.DictReader(fh) if r["kind"] == "inter"]
        out[(world, align)] = [(r["relevant"] == "true", r["correct"] == "true", int(r["n_assoc"])) for r in rows]
    return out


def _k(rows: list[tuple[bool, bool, int]]) -> int | None:
    for k in KS:
        tp = sum(1 for rel, ok, n in rows if n >= k and rel and ok)
        fp = sum(1 for rel, ok, n in rows if n >= k and not ok)
        if tp + fp and 10 * tp >= 9 * (tp + fp):
            return k
    return None


@pytest.fixture(scope="module")
def home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("tune")
    (d / "tiny.yaml").write_text(SUITE)
    code, output = _tune(d, "cos_min=0.85")
    assert code == 0, output
    return d


def test_figures_follow_from_the_raw_pairs(home: Path):
    res = read_tune(home / "t" / "tune.json")
    assert [w.id for w in res.worlds] == ["distinct-s0", "distinct-s1"]
    assert all(w.km > 0.05 for w in res.worlds)
    hand = _by_hand(home)
    assert len(hand) == 2 and len(res.configs) == 1
    row = res.configs[0]
    rows = {w: r for (w, _), r in hand.items()}
    hits = fps = rel = 0
    per_world = {}
    for w, other in (("distinct-s0", "distinct-s1"), ("distinct-s1", "distinct-s0")):
        k = _k(rows[other])  # chosen on the other world only
        assert row.thresholds[w] == k
        h = sum(1 for r, ok, n in rows[w] if k is not None and n >= k and r and ok)
        f = sum(1 for r, ok, n in rows[w] if k is not None and n >= k and not ok)
        per_world[w] = (h, f)
        hits, fps = hits + h, fps + f
        rel += sum(1 for r, _, _ in rows[w] if r)
    assert [row.hits, row.false_positives, row.n_relevant] == [hits, fps, rel]
    km = sum(w.km for w in res.worlds)
    assert row.false_per_km == pytest.approx(fps / km, rel=1e-4)  # km stored to the metre
    assert row.time_per_pair_s is not None and row.time_per_pair_s > 0
    # one config: the setting chosen for each world is that config at the threshold of the other world
    assert res.held_out.hits == hits and res.held_out.false_positives == fps
    assert {w: (p.hits, p.false_positives) for w, p in res.held_out.per_world.items()} == per_world
    # one new world: at least every held-out world's Wilson interval and the pooled interval
    stated = res.held_out.precision_new_world
    spans = [p.precision_wilson for p in res.held_out.per_world.values() if p.precision_wilson is not None]
    spans += [res.held_out.precision_worlds] if res.held_out.precision_worlds is not None else []
    assert stated == (None if not spans else [min(a for a, _ in spans), max(b for _, b in spans)])
    assert {w: None if c is None else c.threshold for w, c in res.held_out.chosen.items()} == row.thresholds
    all_rows = rows["distinct-s0"] + rows["distinct-s1"]
    rec = res.recommended
    assert rec is not None and rec.threshold == _k(all_rows) and rec.values == {"cos_min": 0.85}
    assert res.config(rec.config) is row
    assert (home / "t" / "front.png").stat().st_size > 1000


def _tune_level(home: Path, out: str, *args: str) -> tuple[int, str]:
    cmd = ["tune", str(home / "levelled.yaml"), "--out", str(home / out), "--param", "threshold=1:8", "--rule", "point"]
    res = CliRunner().invoke(app, [*cmd, "--param", "cos_min=0.85", *args])
    return res.exit_code, res.output


def test_one_level_tunes_on_its_worlds_only(home: Path):
    (home / "levelled.yaml").write_text(LEVELLED)
    lv = home / "lv"
    for part in ("work", "cache"):  # the same worlds as the all-level tune: its runs are read back
        shutil.copytree(home / "t" / part, lv / part)
    kept = {p.relative_to(lv): p.stat().st_mtime_ns for p in lv.glob("work/*/*/outcomes.json")}
    code, output = _tune_level(home, "lv", "--level", "distinct", "--seeds", "0:2")
    assert code == 0, output
    assert {p.relative_to(lv): p.stat().st_mtime_ns for p in lv.glob("work/*/*/outcomes.json")} == kept
    assert "tune roman (level distinct)" in output
    assert sorted(p.name for p in (lv / "work").iterdir()) == ["distinct-s0", "distinct-s1"]  # no twin world
    res, whole = read_tune(lv / "tune.json"), read_tune(home / "t" / "tune.json")
    assert res.level == "distinct" and whole.level is None
    assert json.loads((lv / "tune.json").read_text())["level"] == "distinct"
    assert "level" not in json.loads((home / "t" / "tune.json").read_text())  # left out when every level is tuned
    assert json.loads((lv / "job.json").read_text())["level"] == "distinct"
    # the same two worlds as the one-level suite's tune: the same figures from the same pairs
    assert [w.id for w in res.worlds] == ["distinct-s0", "distinct-s1"]
    hand = {w: r for (w, _), r in _by_hand(home).items()}
    row = res.configs[0]
    assert row.thresholds == {"distinct-s0": _k(hand["distinct-s1"]), "distinct-s1": _k(hand["distinct-s0"])}
    assert (row.hits, row.false_positives) == (whole.configs[0].hits, whole.configs[0].false_positives)
    assert res.held_out == whole.held_out and res.recommended == whole.recommended
    assert (lv / "recommended.yaml").read_text().startswith("# roman-sim tune: roman on")
    assert ", level distinct, target precision 0.9" in (lv / "recommended.yaml").read_text().splitlines()[0]
    write_tune(home / "lv-copy.json", res)
    assert (home / "lv-copy.json").read_bytes() == (lv / "tune.json").read_bytes()


def test_another_level_on_the_same_folder_is_refused(home: Path):
    lv = home / "lv"
    before = (lv / "tune.json").read_bytes()
    for args in (["--level", "twin", "--seeds", "0:2"], ["--seeds", "0:2"]):
        code, output = _tune_level(home, "lv", *args)
        assert code == 1
        assert output.strip().splitlines() == [
            f"error: --out {lv}: holds the tune of 'roman' on '{home / 'levelled.yaml'} level distinct' "
            "with overrides [] (choose another --out)"
        ]
    assert (lv / "tune.json").read_bytes() == before
    assert sorted(p.name for p in (lv / "work").iterdir()) == ["distinct-s0", "distinct-s1"]


def test_a_bad_level_names_the_valid_ones_before_anything_runs(home: Path):
    code, output = _tune_level(home, "bad", "--level", "medium", "--seeds", "0:2")
    assert code == 1
    assert output.strip().splitlines() == [
        f"error: --level: {home / 'levelled.yaml'} has no level 'medium' (valid: distinct, twin)"
    ]
    res = CliRunner().invoke(app, ["tune", "smoke", "--out", str(home / "bad"), "--level", "low"])
    assert res.exit_code == 1
    assert res.output.strip().splitlines() == [
        "error: --level: smoke is a scenario, which has no levels "
        "(valid: none; --level takes a benchmark suite's level)"
    ]
    assert not (home / "bad").exists()


def test_the_result_file_round_trips_and_a_damaged_one_names_the_field(home: Path, tmp_path: Path):
    path = home / "t" / "tune.json"
    res = read_tune(path)
    write_tune(tmp_path / "tune.json", res)
    assert (tmp_path / "tune.json").read_bytes() == path.read_bytes()
    data = json.loads(path.read_text())
    data["configs"][0]["hits"] = "many"
    (tmp_path / "tune.json").write_text(json.dumps(data))
    with pytest.raises(RecordError) as err:
        read_tune(tmp_path / "tune.json")
    assert (
        str(err.value) == f"{tmp_path / 'tune.json'}: field configs[0].hits: expected an integer, got a string ('many')"
    )


def test_recommended_yaml_loads_into_a_scenario(home: Path):
    res = read_tune(home / "t" / "tune.json")
    path = home / "t" / "recommended.yaml"
    text = path.read_text()
    assert text.startswith("# roman-sim tune: roman on")
    sc = load_scenario("smoke", [f"@{path}"])
    assert [(e.method, e.params) for e in sc.aligners] == [("roman", {"cos_min": 0.85})]
    assert res.recommended is not None and sc.posegraph.lc_association_thresh == res.recommended.threshold
    assert sc.posegraph_method == "roman" and not sc.gating.enabled


def test_resume_reuses_and_a_new_alignment_does_not_remap(home: Path):
    t = home / "t"
    before = {p: p.stat().st_mtime_ns for p in t.glob("work/*/*/outcomes.json")}
    code, output = _tune(home, "cos_min=0.85")
    assert code == 0, output
    assert {p: p.stat().st_mtime_ns for p in t.glob("work/*/*/outcomes.json")} == before  # nothing re-run
    # interrupted after a world's run folder finished but before its outcomes were kept: read back, not re-run
    lost = sorted(before)[0]
    kept = lost.read_bytes()
    lost.unlink()
    code, output = _tune(home, "cos_min=0.85")
    assert code == 0, output
    assert lost.read_bytes() == kept
    stages = json.loads((lost.parent / "run" / "timings.json").read_text())["stages"]
    assert all(s["reused"] for s in stages.values() if "reused" in s), stages
    before[lost] = lost.stat().st_mtime_ns
    # gating only changes the evaluation: still nothing aligned again
    code, output = _tune(home, "cos_min=0.85", "gating.top_k=1,10000")
    assert code == 0, output
    assert {p: p.stat().st_mtime_ns for p in t.glob("work/*/*/outcomes.json")} == before
    res = json.loads((t / "tune.json").read_text())
    wide = next(c for c in res["configs"] if c["values"]["gating.top_k"] == 10000)
    narrow = next(c for c in res["configs"] if c["values"]["gating.top_k"] == 1)
    assert wide["n_relevant"] == narrow["n_relevant"]
    assert narrow["time_per_pair_s"] < wide["time_per_pair_s"]  # gated-out pairs cost nothing
    # a new aligner value: one new alignment per world, the maps reused
    code, output = _tune(home, "cos_min=0.85,0.9")
    assert code == 0, output
    after = {p: p.stat().st_mtime_ns for p in t.glob("work/*/*/outcomes.json")}
    assert len(after) == 4 and all(after[p] == m for p, m in before.items())
    for new in set(after) - set(before):
        stages = json.loads((new.parent / "run" / "timings.json").read_text())["stages"]
        assert stages["maps"]["reused"] and stages["submaps"]["reused"] and not stages["evaluation"]["reused"]


def test_bad_parameter_on_a_finished_folder(home: Path):
    before = (home / "t" / "tune.json").read_bytes()
    code, output = _tune(home, "radius=1:2")
    assert code == 1
    assert output.strip().splitlines() == [
        "error: --param radius: roman does not declare it "
        "(declared: threshold, gating.top_k, gating.min_similarity, cos_min, cos_max)"
    ]
    assert (home / "t" / "tune.json").read_bytes() == before


class _FourAssociations(RomanParams):
    """ROMAN's parameters with another default (as if its code had been edited)."""

    min_associations_for_transform: int = 4


def test_a_changed_default_of_the_tuned_aligner_aligns_again_without_remapping(home: Path, monkeypatch):
    t = home / "t"
    code, output = _tune(home, "cos_min=0.85")
    assert code == 0, output
    before = {p: p.stat().st_mtime_ns for p in t.glob("work/*/*/outcomes.json")}
    code, output = _tune(home, "cos_min=0.85")
    assert code == 0, output
    assert {p: p.stat().st_mtime_ns for p in t.glob("work/*/*/outcomes.json")} == before  # no change: reused
    monkeypatch.setattr(RomanAligner, "params_model", _FourAssociations)
    code, output = _tune(home, "cos_min=0.85")
    assert code == 0, output
    tuned = [p for p in before if p.parent.name == Config((("cos_min", 0.85),), ()).align_key]
    assert len(tuned) == 2
    for p in tuned:  # every world's alignment of the tuned value ran again, on the same maps
        assert p.stat().st_mtime_ns != before[p]
        stages = json.loads((p.parent / "run" / "timings.json").read_text())["stages"]
        assert stages["maps"]["reused"] and stages["submaps"]["reused"] and not stages["evaluation"]["reused"]
        params = yaml.safe_load((p.parent / "run" / "config.yaml").read_text())["aligners"][0]["params"]
        assert params["min_associations_for_transform"] == 4


def test_the_lower_rule_is_recorded_and_another_rule_is_refused(home: Path):
    lo = home / "lo"
    for part in ("work", "cache"):  # the same worlds: the runs are read back
        shutil.copytree(home / "t" / part, lo / part)
    args = ["tune", str(home / "tiny.yaml"), "--out", str(lo), "--param", "threshold=1:8", "--param", "cos_min=0.85"]
    res = CliRunner().invoke(app, [*args, "--rule", "lower"])
    assert res.exit_code == 0, res.output
    got, point = read_tune(lo / "tune.json"), read_tune(home / "t" / "tune.json")
    assert json.loads((lo / "tune.json").read_text())["rule"] == "lower" and got.rule == "lower"
    assert json.loads((lo / "job.json").read_text())["rule"] == "lower"
    assert "rule" not in json.loads((home / "t" / "tune.json").read_text()) and point.rule is None
    assert got.configs == point.configs  # the config rows do not depend on the rule
    # by hand from pairs.csv: the smallest threshold at which every world's Wilson lower end reaches 0.9
    # (the hull's lower end is at most each world's), else nothing
    z2 = 1.959963984540054**2
    rows = {w: r for (w, _), r in _by_hand(home).items()}

    def world_ok(r: list[tuple[bool, bool, int]], k: int) -> bool:
        tp = sum(1 for rel, ok, n in r if n >= k and rel and ok)
        fp = sum(1 for rel, ok, n in r if n >= k and not ok)
        if tp + fp == 0:
            return False
        n, p = tp + fp, tp / (tp + fp)
        low = (p + z2 / (2 * n) - (z2**0.5) * (p * (1 - p) / n + z2 / (4 * n * n)) ** 0.5) / (1 + z2 / n)
        return low >= 0.9 - 1e-12

    candidates = [k for k in KS if all(world_ok(r, k) for r in rows.values())]
    if not candidates:
        assert got.recommended is None
    if got.recommended is None:  # (with candidates, the pooled bootstrap's lower end fell short)
        assert "(--rule lower): nothing recommended" in res.output
        assert not (lo / "recommended.yaml").exists()
    else:
        assert got.recommended.threshold in candidates
        assert ", rule lower" in (lo / "recommended.yaml").read_text().splitlines()[0]
    before = (lo / "tune.json").read_bytes()
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 1
    assert res.output.strip().splitlines() == [
        f"error: --out {lo}: holds the tune of 'roman' on '{home / 'tiny.yaml'}' with overrides [] by rule lower "
        "(choose another --out)"
    ]
    assert (lo / "tune.json").read_bytes() == before


def _grid_share(per_world: list[tuple[int, int]], x: float) -> float:
    """The share of new worlds at ``x`` or more of the beta-binomial fitted to (hits, accepted) by a grid search
    of scipy's pmf (independent of the tune's optimiser)."""
    h = [a for a, n in per_world if n]
    n = [n for _, n in per_world if n]
    best = max(
        (float(stats.betabinom.logpmf(h, n, m * c, (1 - m) * c).sum()), m, c)
        for m in np.linspace(0.5, 0.9999, 200)
        for c in np.geomspace(0.05, 1e5, 120)
    )
    return float(stats.beta.sf(x, best[1] * best[2], (1 - best[1]) * best[2]))


def test_the_world_rule_is_the_default_and_states_the_spread_of_its_choice(home: Path):
    wr = home / "wr"
    for part in ("work", "cache"):  # the same worlds: the runs are read back
        shutil.copytree(home / "t" / part, wr / part)
    args = ["tune", str(home / "tiny.yaml"), "--out", str(wr), "--param", "threshold=1:8", "--param", "cos_min=0.85"]
    res = CliRunner().invoke(app, args)  # the default rule
    assert res.exit_code == 0, res.output
    got, point = read_tune(wr / "tune.json"), read_tune(home / "t" / "tune.json")
    assert got.rule == "world" and json.loads((wr / "job.json").read_text())["rule"] == "world"
    assert got.configs == point.configs
    rows = {w: r for (w, _), r in _by_hand(home).items()}

    def per_world(k: int) -> list[tuple[int, int]]:
        out = []
        for r in rows.values():
            tp = sum(1 for rel, ok, n in r if n >= k and rel and ok)
            out.append((tp, sum(1 for _, ok, n in r if n >= k and not ok) + tp))
        return out

    # by hand: the smallest threshold whose worlds' spread puts 90 % of new worlds at 0.85 or more; a grid fit
    # is coarser than the tune's, so a share within 0.02 of 0.9 decides nothing
    rec = got.recommended
    k_rec = 9 if rec is None else rec.threshold
    for k in range(1, k_rec):
        if sum(1 for _, n in per_world(k) if n) >= 2:
            assert _grid_share(per_world(k), 0.85) < 0.92, k
    if rec is None:
        assert "(--rule world): nothing recommended" in res.output
        return
    sp = rec.spread
    assert sp is not None and sp.worlds == sum(1 for _, n in per_world(rec.threshold) if n)
    assert _grid_share(per_world(rec.threshold), 0.85) > 0.88
    # the stated figures follow from the stated Beta(a, b)
    assert sp.mean == pytest.approx(sp.a / (sp.a + sp.b))
    assert sp.share_within_slack == pytest.approx(float(stats.beta.sf(0.85, sp.a, sp.b)))
    assert sp.share_at_target == pytest.approx(float(stats.beta.sf(0.9, sp.a, sp.b)))
    assert sp.interval == pytest.approx(list(stats.beta.ppf([0.025, 0.975], sp.a, sp.b)))
    head = (wr / "recommended.yaml").read_text().splitlines()
    assert ", rule world" in head[0]
    assert any(line.startswith(f"# worlds' spread (beta-binomial over {sp.worlds} worlds)") for line in head)
    assert f"{sp.share_within_slack:.1%} at 0.85 or more" in " ".join(res.output.split())  # wrapped lines


def test_a_bad_rule_names_the_allowed_values_before_anything_runs(home: Path):
    res = CliRunner().invoke(app, ["tune", str(home / "tiny.yaml"), "--out", str(home / "badrule"), "--rule", "up"])
    assert res.exit_code == 1
    assert res.output.strip().splitlines() == ["error: --rule: expected one of point, lower, world, got 'up'"]
    assert not (home / "badrule").exists()
