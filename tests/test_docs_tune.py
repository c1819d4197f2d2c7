"""The cost and transfer of ``roman-sim tune`` the docs state follow from ``benchmarks/out/tune.json``."""

from __future__ import annotations

import json
from pathlib import Path

from committed_results import BENCHMARKS_OUT

ROOT = Path(__file__).resolve().parents[1]


def _ci(v: list[float]) -> str:
    return f"[{v[0]:.2f}, {v[1]:.2f}]"


def _loads(d: dict) -> tuple[str, str]:
    """The load averages before and after, as the docs state them (lowest-highest)."""
    b, a = d["load_before"], d["load_after"]
    return f"{min(b):.1f}-{max(b):.1f}", f"{min(a):.1f}-{max(a):.1f}"


def _recommended(rec: dict, h: dict, text: str) -> None:
    """The docs state the recommended setting and its calibration recall as hits over relevant pairs."""
    ((name, value),) = rec["values"].items()
    cal_hits = round(rec["calibration_recall"] * h["n_relevant"])
    assert abs(cal_hits / h["n_relevant"] - rec["calibration_recall"]) < 1e-9
    assert (
        f"Recommended: `{name}` {value:g}, threshold {rec['threshold']}, at a calibration recall of "
        f"{rec['calibration_recall']:.2f} ({cal_hits} / {h['n_relevant']})" in text
    )


def test_tune_figures_in_the_docs():
    d = json.loads((BENCHMARKS_OUT / "tune.json").read_text(encoding="utf-8"))
    text = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    assert d["suite"] == "quick" and d["method"] == "roman" and d["workers"] == 1  # one process: all CPU counted
    assert not any(d["maps_reused"].values()) and len(d["worlds"]) == 3  # every world mapped fresh
    before, after = _loads(d)
    assert (
        f"in one process: {d['cpu_s']:.0f} s of CPU time, so about {d['cpu_s'] / 2:.0f} s on 2 free cores if both "
        f"were kept busy ({d['cpu_s']:.0f} s on one). The wall time, {d['wall_s']:.0f} s, was taken on a 2-core "
        f"machine shared with other jobs (load average {before} before, {after} after)" in text
    )
    assert d["cpu_over_2_cores_s"] == round(d["cpu_s"] / 2, 1)
    rec, h, c = d["recommended"], d["held_out"], d["check_on_unseen_worlds"]
    _recommended(rec, h, text)
    assert (
        f"{h['hits']} hits and {h['false_positives']} false positive, precision {h['precision']:.2f} with a 95 % "
        f"world interval {_ci(h['precision_worlds'])} and, for one new world, {_ci(h['precision_new_world'])}" in text
    )
    assert h["hits"] + h["false_positives"] == 1  # "a statement about one accepted pair"
    accepted = [w for w, v in c["per_world"].items() if v["precision"] is not None]
    n = len(c["per_world"])
    assert c["seeds"] == [1, 2, 3] and n == 9
    assert (
        f"that setting reached precision {c['precision']:.2f} ({c['hits']} / {c['hits'] + c['false_positives']}, "
        f"Wilson {_ci(c['precision_wilson'])}) at recall {c['recall']:.2f} ({c['hits']} / {c['n_relevant']}); "
        f"{n - len(accepted)} of the 9 worlds accepted nothing, none of the {len(accepted)} that accepted a pair "
        "lies in the one-new-world interval, and no seed's precision pooled over the levels lies in the pooled "
        "interval" in text
    )
    assert c["worlds_inside_new_world_interval"] == [0, len(accepted)]
    assert c["seeds_inside_pooled_interval"][0] == 0
    assert d["reaches_target"] is True and d["within_stated_interval"] is False
    assert "The target is reached, but not within the stated interval" in text


def _frac(v: dict) -> str:
    """``0.94 (34 / 36)`` of a record with hits, false positives and precision."""
    return f"{v['precision']:.2f} ({v['hits']} / {v['hits'] + v['false_positives']})"


def test_level_tune_figures_in_the_docs():
    whole = json.loads((BENCHMARKS_OUT / "tune.json").read_text(encoding="utf-8"))
    d = whole["level_tunes"]["low"]
    text = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    assert d["level"] == "low" and d["seeds"] == [0, 1, 2, 3] and d["workers"] == 1  # one process: all CPU counted
    assert d["worlds"] == [f"low-s{s}" for s in d["seeds"]] and not any(d["maps_reused"].values())
    assert (
        "`python benchmarks/bench_tune.py FOLDER --level low --seeds 0:4 --check-seeds 4,5,6 --check-cache DIR`" in text
    )
    before, after = _loads(d)
    assert (
        f"Tuned on the low level's four worlds of seeds 0-3 ({d['alignments']} alignments each, every world mapped "
        f"fresh, in one process): {d['cpu_s']:.0f} s of CPU time, so about {d['cpu_s'] / 2:.0f} s on 2 free cores "
        f"({d['cpu_s']:.0f} s on one; wall time {d['wall_s']:.0f} s on the shared machine, load average "
        f"{before} before, {after} after)" in text
    )
    assert d["cpu_s"] / 2 <= 300  # "within 5 minutes on 2 cores"
    assert "The cost is within 5 minutes on 2 cores" in text
    rec, h, c = d["recommended"], d["held_out"], d["check_on_unseen_worlds"]
    _recommended(rec, h, text)
    per_world = [_frac(h["per_world"][w]) for w in d["worlds"]]
    assert (
        f"Held-out (each world at the setting chosen on the other three): {h['hits']} hits and "
        f"{h['false_positives']} false positives, precision {h['precision']:.2f} with a 95 % world interval "
        f"{_ci(h['precision_worlds'])}; per world {', '.join(per_world[:-1])} and {per_world[-1]}; for one new "
        f"world {_ci(h['precision_new_world'])}" in text
    )
    unseen = [f"low-s{s}" for s in c["seeds"]]
    assert c["seeds"] == [4, 5, 6] and sorted(c["per_world"]) == unseen
    each = [_frac(c["per_world"][w]) for w in unseen]
    assert (
        f"On the three low worlds of seeds 4-6 the tune never saw, that setting reached precision "
        f"{', '.join(each[:-1])} and {each[-1]}: pooled {c['precision']:.2f} ({c['hits']} / "
        f"{c['hits'] + c['false_positives']}, Wilson {_ci(c['precision_wilson'])}) at recall {c['recall']:.2f} "
        f"({c['hits']} / {c['n_relevant']})" in text
    )
    reach, n = c["worlds_reaching_target"]
    inside, m = c["worlds_inside_new_world_interval"]
    assert (reach, n, inside, m) == (1, 3, 2, 3)
    (out,) = [w for w in unseen if not c["per_world"][w]["inside_new_world_interval"]]
    assert c["per_world"][out]["precision"] < h["precision_new_world"][0]  # below it, not above
    assert (
        f"One of the three worlds reaches the target; two of the three lie in the one-new-world interval, the "
        f"third ({c['per_world'][out]['precision']:.2f}) below it" in text
    )
    assert c["precision"] < h["precision_worlds"][0] and c["precision"] < 0.9 - 0.05
    assert "the pooled precision lies below the pooled held-out interval and more than 0.05 short of the target" in text
    assert d["reaches_target"] is False and d["within_stated_interval"] is False
    assert d["within_slack_of_target"] is False
    assert "the transfer is not met" in text
    lo = min(v["precision"] for v in h["per_world"].values())
    hi = max(v["precision"] for v in h["per_world"].values())
    new_lo = min(v["precision"] for v in c["per_world"].values())
    new_hi = max(v["precision"] for v in c["per_world"].values())
    assert f"the four held-out worlds gave {lo:.2f}-{hi:.2f}, the three new ones {new_lo:.2f}-{new_hi:.2f}" in text


def test_rule_tune_figures_in_the_docs():
    whole = json.loads((BENCHMARKS_OUT / "tune.json").read_text(encoding="utf-8"))
    d = whole["rule_tunes"]["low-lower"]
    text = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    assert d["level"] == "low" and d["rule"] == "lower" and d["seeds"] == [0, 1, 2, 3]
    assert d["worlds"] == [f"low-s{s}" for s in d["seeds"]] and d["alignments_read_back"] is True
    assert (
        "`python benchmarks/bench_tune.py FOLDER --level low --seeds 0:4 --rule lower --check-seeds 7,8,9 "
        "--reuse DIR --check-cache DIR`" in text
    )
    assert "figures in `rule_tunes.low-lower` of the same file" in text
    # the lower rule: nothing qualifies, so nothing is recommended, nothing is checked, nothing held out
    assert d["recommended"] is None and d["check_on_unseen_worlds"] is None
    assert all(v is None for v in d["held_out"]["chosen"].values()) and d["held_out"]["hits"] == 0
    assert "Under the lower rule no setting qualifies on the four worlds of seeds 0-3" in text
    b = d["best_lowest_world_wilson"]
    assert b["value"] < 0.9
    assert (
        f"the highest lowest-world Wilson lower end is {b['value']:.2f} (`cos_min` {b['values']['cos_min']}, "
        f"threshold {b['threshold']})" in text
    )
    p = d["point_rule"]
    ph = p["held_out"]
    sizes = [v["hits"] + v["false_positives"] for v in ph["per_world"].values()]
    assert f"the four worlds accepted {min(sizes)}-{max(sizes)} pairs each" in text
    z2 = 1.959963984540054**2
    assert 34 / (34 + z2) < 0.9 <= 35 / (35 + z2)  # n / n has Wilson lower end n / (n + z^2)
    assert "unless it accepts 35 pairs or more" in text
    rec = p["recommended"]
    assert (
        f"The point rule, scored from the same alignments, recommends `cos_min` {rec['values']['cos_min']}, "
        f"threshold {rec['threshold']}, with the one-new-world interval {_ci(ph['precision_new_world'])}" in text
    )
    # the same setting as the --level low run above
    lv = whole["level_tunes"]["low"]["recommended"]
    assert (rec["values"], rec["threshold"]) == (lv["values"], lv["threshold"])
    c = p["check_on_unseen_worlds"]
    fresh = [f"low-s{s}" for s in (7, 8, 9)]
    assert c["seeds"] == [7, 8, 9] and sorted(c["per_world"]) == fresh
    assert not set(c["seeds"]) & {4, 5, 6} and not set(c["seeds"]) & set(d["seeds"])
    each = [_frac(c["per_world"][w]) for w in fresh]
    assert (
        f"on seeds 7-9 that setting reached {', '.join(each[:-1])} and {each[-1]}: pooled {c['precision']:.2f} "
        f"({c['hits']} / {c['hits'] + c['false_positives']}, Wilson {_ci(c['precision_wilson'])}) at recall "
        f"{c['recall']:.2f} ({c['hits']} / {c['n_relevant']})" in text
    )
    assert c["worlds_reaching_target"] == [1, 3] and c["worlds_inside_new_world_interval"] == [3, 3]
    assert "One of the three worlds reaches the target and all three lie in the stated interval" in text
    assert c["precision"] < 0.9
    assert f"the point rule misses the target (pooled {c['precision']:.2f}) within its interval" in text
    assert f"its price is the whole recall of {c['recall']:.2f}" in text


def _spread_text(sp: dict) -> str:
    return (
        f"a new world's precision {sp['mean']:.2f} expected, 95 % of worlds in {_ci(sp['interval'])}, "
        f"{sp['share_at_target']:.1%} at 0.9 or more and {sp['share_within_slack']:.1%} at 0.85 or more"
    )


def test_world_rule_figures_in_the_docs():
    """The world rule on seven low worlds, checked on 18 fresh ones, against the point rule on the same alignments;
    each world's hits against the 95 % interval of BetaBinomial(n, a, b), recomputed here with scipy."""
    from scipy import stats

    whole = json.loads((BENCHMARKS_OUT / "tune.json").read_text(encoding="utf-8"))
    d = whole["rule_tunes"]["low-world"]
    text = " ".join((ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8").split())
    assert d["level"] == "low" and d["rule"] == "world" and d["seeds"] == list(range(7))
    assert d["worlds"] == [f"low-s{s}" for s in d["seeds"]] and not any(d["maps_reused"].values())
    assert d["alignments_read_back"] is False and d["workers"] == 2
    assert (
        "`python benchmarks/bench_tune.py FOLDER --level low --seeds 0:7 --rule world "
        "--check-seeds 13:31 --workers 2 --check-cache DIR`" in text
    )
    assert "figures in `rule_tunes.low-world` of the same file" in text
    before, after = _loads(d)
    assert (
        f"Tuned on the low level's seven worlds of seeds 0-6 ({d['alignments']} alignments each, every world mapped "
        f"fresh, two workers): {d['wall_s']:.0f} s of wall time on 2 cores (load average {before} before, {after} "
        f"after) and {d['cpu_s']:.0f} s of CPU time" in text
    )
    assert d["wall_s"] <= 300 and "The cost is within 5 minutes on 2 cores" in text
    rec, h, c = d["recommended"], d["held_out"], d["check_on_unseen_worlds"]
    _recommended(rec, h, text)
    sp = rec["spread"]
    assert sp["worlds"] == 7 and sp["share_within_slack"] >= 0.9
    assert abs(sp["share_within_slack"] - float(stats.beta.sf(0.85, sp["a"], sp["b"]))) < 1e-9
    assert f"Its spread over the seven worlds: {_spread_text(sp)}" in text
    assert (
        f"Held-out (each world at the setting chosen on the other six): precision {h['precision']:.2f} "
        f"({h['hits']} / {h['hits'] + h['false_positives']}) with a 95 % world interval {_ci(h['precision_worlds'])}"
        in text
    )
    p = d["point_rule"]
    prec, psp, ph = p["recommended"], p["recommended"]["spread"], p["held_out"]
    assert psp["share_within_slack"] < 0.9
    assert (
        f"The point rule, scored from the same alignments, recommends `cos_min` {prec['values']['cos_min']}, "
        f"threshold {prec['threshold']} (held-out precision {ph['precision']:.2f}); at that setting the seven worlds' "
        f"spread puts {psp['share_within_slack']:.1%} of new worlds at 0.85 or more" in text
    )
    fresh = [f"low-s{s}" for s in range(13, 31)]
    assert c["seeds"] == list(range(13, 31)) and sorted(c["per_world"]) == sorted(fresh)
    assert not set(c["seeds"]) & set(range(13))  # never used before: calibration 0-6, earlier checks 4-12
    precisions = [c["per_world"][w]["precision"] for w in fresh]
    assert (
        f"On the 18 fresh worlds that setting reached pooled {c['precision']:.2f} ({c['hits']} / "
        f"{c['hits'] + c['false_positives']}, Wilson {_ci(c['precision_wilson'])}, world bootstrap "
        f"{_ci(c['precision_worlds'])}) at recall {c['recall']:.2f} ({c['hits']} / {c['n_relevant']}), per world "
        f"{min(precisions):.2f}-{max(precisions):.2f}" in text
    )
    assert c["precision"] >= 0.9 and d["reaches_target"] is True
    # each world's hits against the interval its own number of accepted pairs gives, by scipy here
    outside = []
    for w in fresh:
        v = c["per_world"][w]
        n = v["hits"] + v["false_positives"]
        lo, hi = (int(x) for x in stats.betabinom.ppf([0.025, 0.975], n, sp["a"], sp["b"]))
        assert v["inside_spread_interval"] == bool(lo <= v["hits"] <= hi), w
        if not v["inside_spread_interval"]:
            outside.append((v, lo, hi))
    reach = sum(1 for p in precisions if p >= 0.9)
    assert [reach, 18] == c["worlds_reaching_target"] and c["worlds_inside_new_world_interval"] == [18, 18]
    assert f"{reach} of the 18 reach 0.9 and all 18 lie in the one-new-world interval" in text
    assert f"for one new world {_ci(h['precision_new_world'])}" in text
    ((v, lo, hi),) = outside
    assert v["hits"] == lo - 1
    assert (
        f"17 of the 18 have as many hits as it gives a world that accepts as many pairs (its 95 % interval); the "
        f"eighteenth, {_frac(v)}, has one hit fewer than the {lo}-{hi} it gives a world of "
        f"{v['hits'] + v['false_positives']} pairs: seven worlds understate the spread" in text
    )
    pc = p["check_on_unseen_worlds"]
    assert pc["seeds"] == c["seeds"] and pc["precision"] < 0.9 - 0.05
    pp = [pc["per_world"][w]["precision"] for w in fresh]
    assert (
        f"The point rule's setting reached {pc['precision']:.2f} pooled on the same 18 worlds ({pc['hits']} / "
        f"{pc['hits'] + pc['false_positives']}, Wilson {_ci(pc['precision_wilson'])}) at recall "
        f"{pc['recall']:.2f}, per world {min(pp):.2f}-{max(pp):.2f}; {pc['worlds_reaching_target'][0]} of the 18 "
        "reach 0.9" in text
    )
    assert f"reaches the target precision, pooled and in {reach} of 18 worlds" in text
    assert f"the world rule pays for it in recall ({c['recall']:.2f} against {pc['recall']:.2f})" in text
    assert c["precision"] >= 0.9 and d["within_stated_interval"] is True
