"""The paper preset: severity scaling, the resumable 1-D fit, its admitted settings and the held-out predictions.

The real fit runs whole scenarios; here stubbed run functions stand in for them (no
rendering): their counts (hits of relevant pairs) follow the severity they are given, so the
search's result, the admitted settings and every claim are known by hand.
"""

import json

import pytest
import yaml
from typer.testing import CliRunner

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.records import RecordError
from roman_sim.evaluation.intervals import wilson
from roman_sim.frontend.components import FrontEndConfig, build_encoder, build_segmenter
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.studies import paper_preset
from roman_sim.studies.paper_preset import PaperFitConfig, fit_paper_preset, predict_paper_preset


def _severity(overrides):
    return float(next(o for o in overrides if o.startswith("frontend.severity=")).split("=", 1)[1])


class Stub:
    """recall(severity) = 0.95 - 0.2 severity for ROMAN, in hits of 200 relevant pairs; the opposite
    direction gives fixed counts."""

    def __init__(self, fail_after=None, opposite=None):
        self.calls = []
        self.fail_after = fail_after
        self.opposite = opposite or {"roman": (56, 200), "ransac1m": (40, 200), "clipper": (20, 200)}

    def __call__(self, scenario, overrides, run_dir):
        if self.fail_after is not None and len(self.calls) >= self.fail_after:
            raise KeyboardInterrupt
        self.calls.append((scenario, list(overrides)))
        # Every run's overrides load as a scenario (here on the tiny smoke scenario).
        load_scenario("smoke", [o for o in overrides if o.startswith(("frontend.", "aligners="))])
        if scenario == "opposite_direction":
            return dict(self.opposite)
        s = _severity(overrides)
        return {"roman": (round(200 * (0.95 - 0.2 * s)), 200), "clipper": (round(200 * (0.9 - 0.3 * s)), 200)}


CFG = PaperFitConfig(grid=[0.0, 1.0, 2.0, 3.0], refine=3)


def test_fit_brackets_then_bisects_and_writes_a_preset(tmp_path):
    stub = Stub()
    res = fit_paper_preset(tmp_path, CFG, stub)
    # 0.95 - 0.2 s = 0.67 at s = 1.4: grid 0..3, bracket [1, 2], then 1.5, 1.25, 1.375.
    assert [_severity(o) for _, o in stub.calls] == [0.0, 1.0, 2.0, 3.0, 1.5, 1.25, 1.375]
    assert res.severity == 1.375 and res.fitted == pytest.approx(0.95 - 0.2 * 1.375)
    assert res.paper == 0.67 and all(sc == "same_direction" for sc, _ in stub.calls)
    assert all("aligners=[roman]" in o for _, o in stub.calls)  # the fit needs ROMAN only
    # paper_fit.yaml is a preset file: the preset's parameters at the fitted severity.
    path = tmp_path / "paper_fit.yaml"
    fe = validate_model(FrontEndConfig, {"preset": str(path)})
    at = validate_model(FrontEndConfig, {"preset": "paper", "severity": 1.375})
    assert build_segmenter(fe).cfg == build_segmenter(at).cfg
    assert build_encoder(fe).cfg == build_encoder(at).cfg
    assert yaml.safe_load(path.read_text())["fit"]["searched"][0] == [0.0, 0.95]


def test_fit_resumes_and_refuses_another_configuration(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        fit_paper_preset(tmp_path, CFG, Stub(fail_after=5))
    state = json.loads((tmp_path / "fit_state.json").read_text())
    assert len(state["runs"]) == 5
    again = Stub()
    fit_paper_preset(tmp_path, CFG, again)
    assert [_severity(o) for _, o in again.calls] == [1.25, 1.375]  # only the runs not done yet
    rerun = Stub()
    assert fit_paper_preset(tmp_path, CFG, rerun).severity == 1.375 and rerun.calls == []
    with pytest.raises(ConfigError, match="another fit configuration"):
        fit_paper_preset(tmp_path, CFG.model_copy(update={"refine": 1}), Stub())


def test_fit_without_a_bracket_stops_at_the_grid(tmp_path):
    stub = Stub()
    res = fit_paper_preset(tmp_path, PaperFitConfig(grid=[0.0, 0.5], target=0.5), stub)
    assert len(stub.calls) == 2 and res.severity == 0.5


class Counted:
    """A fit and predictions whose counts are set by hand per severity (grid 0..5, no bisection).

    Same direction, ROMAN's hits of 50 relevant pairs, with the 95 % Wilson interval (score
    interval, z = 1.96: centre (p + z^2/2n) / (1 + z^2/n), half-width
    z / (1 + z^2/n) * sqrt(p (1 - p) / n + z^2 / 4n^2)) and whether it contains 0.67:
    0: 45/50 = 0.90 [0.786, 0.957] no; 1: 41/50 = 0.82 [0.692, 0.902] no;
    2: 40/50 = 0.80 [0.6696, 0.888] yes (by 0.0004); 3: 30/50 = 0.60 [0.462, 0.724] yes, and
    the closest to 0.67, so fitted; 4: 27/50 = 0.54 [0.404, 0.6703] yes (by 0.0003);
    5: 26/50 = 0.52 [0.385, 0.652] no. Admitted: 2, 3, 4.
    """

    SAME = {0.0: 45, 1.0: 41, 2.0: 40, 3.0: 30, 4.0: 27, 5.0: 26}
    #: Opposite direction, hits of 50: roman, ransac1m, clipper.
    OPPOSITE = {2.0: (14, 8, 2), 3.0: (12, 10, 4), 4.0: (5, 3, 1)}

    def __init__(self, interrupt_at=None):
        self.calls = []
        self.interrupt_at = interrupt_at

    def __call__(self, scenario, overrides, run_dir):
        if self.interrupt_at is not None and len(self.calls) >= self.interrupt_at:
            raise KeyboardInterrupt
        s = _severity(overrides)
        self.calls.append((scenario, s, list(overrides), run_dir.name))
        if scenario == "opposite_direction":
            return {m: (h, 50) for m, h in zip(("roman", "ransac1m", "clipper"), self.OPPOSITE[s])}
        return {"roman": (self.SAME[s], 50)}


COUNTED = PaperFitConfig(grid=[0.0, 1.0, 2.0, 3.0, 4.0, 5.0], refine=0)


def test_the_admitted_settings_are_those_whose_interval_contains_the_target(tmp_path):
    res = fit_paper_preset(tmp_path, COUNTED, Counted())
    assert res.severity == 3.0 and res.fitted == 0.6
    assert res.admitted == [2.0, 3.0, 4.0]
    runs = {r.severity: r for r in res.runs}
    assert [runs[s].admitted for s in COUNTED.grid] == [False, False, True, True, True, False]
    assert runs[2.0].ci[0] == pytest.approx(0.66963, abs=1e-5)  # just below 0.67: admitted
    assert runs[1.0].ci[0] == pytest.approx(0.69204, abs=1e-5)  # above 0.67: not admitted
    assert runs[4.0].ci[1] == pytest.approx(0.67030, abs=1e-5)  # just above 0.67: admitted
    assert runs[5.0].ci[1] == pytest.approx(0.65203, abs=1e-5)  # below 0.67: not admitted
    assert (runs[3.0].hits, runs[3.0].relevant) == (30, 50)


def test_predictions_at_every_admitted_setting_with_a_verdict(tmp_path):
    fit_paper_preset(tmp_path, COUNTED, Counted())
    stub = Counted()
    res = predict_paper_preset(tmp_path, run=stub)
    assert [(sc, s) for sc, s, _, _ in stub.calls] == [("opposite_direction", s) for s in (2.0, 3.0, 4.0)]
    for _, s, overrides, name in stub.calls:
        assert "aligners=[roman, ransac1m, clipper]" in overrides and "frontend.preset=paper" in overrides
        assert name == f"opposite_direction_{s:.6f}"
    assert res.severity == 3.0 and res.admitted.severities == [2.0, 3.0, 4.0]
    opposite, ordering, ratio = res.claims
    # ROMAN 14/50 = 0.28 and 12/50 = 0.24 lie within 0.26 +- 0.08, 5/50 = 0.10 does not.
    assert [r.holds for r in opposite.settings] == [True, True, False]
    assert opposite.verdict == "some" and opposite.fails_for == [4.0]
    assert opposite.range == pytest.approx((0.10, 0.28))
    assert opposite.settings[0].ci == pytest.approx(wilson(14, 50))
    # ROMAN > RANSAC-1M > CLIPPER at every admitted severity (14 > 8 > 2, 12 > 10 > 4, 5 > 3 > 1).
    assert ordering.verdict == "every" and ordering.holds_for == [2.0, 3.0, 4.0]
    assert ordering.range == {
        "roman": pytest.approx((0.10, 0.28)),
        "ransac1m": pytest.approx((0.06, 0.20)),
        "clipper": pytest.approx((0.02, 0.08)),
    }
    # same / opposite at the same severity: 0.80 / 0.28 = 2.86, 0.60 / 0.24 = 2.5 within 1.97-3.72; 0.54 / 0.10 not.
    assert [r.value for r in ratio.settings] == pytest.approx([0.8 / 0.28, 2.5, 5.4])
    assert ratio.verdict == "some" and ratio.range == pytest.approx((2.5, 5.4))
    assert paper_preset.read_predictions(tmp_path / "paper_predictions.json") == res
    again = Counted()
    predict_paper_preset(tmp_path, run=again)
    assert again.calls == []  # every prediction run is kept


def test_predict_resumes_after_an_interrupt(tmp_path):
    fit_paper_preset(tmp_path, COUNTED, Counted())
    with pytest.raises(KeyboardInterrupt):
        predict_paper_preset(tmp_path, run=Counted(interrupt_at=1))
    state = json.loads((tmp_path / "fit_state.json").read_text())
    assert list(state["predicted"]) == ["2.000000"]  # saved as soon as the run ended
    assert state["predicted"]["2.000000"]["figures"]["roman"] == {"hits": 14, "relevant": 50}
    rest = Counted()
    res = predict_paper_preset(tmp_path, run=rest)
    assert [s for _, s, _, _ in rest.calls] == [3.0, 4.0]
    assert res.claims[0].verdict == "some"


def test_settings_not_run_leave_the_verdict_open(tmp_path):
    fit_paper_preset(tmp_path, COUNTED, Counted())
    with pytest.raises(KeyboardInterrupt):
        predict_paper_preset(tmp_path, run=Counted(interrupt_at=1))
    res = predict_paper_preset(tmp_path, run=Counted(interrupt_at=0), run_missing=False)
    opposite, ordering, _ = res.claims
    assert opposite.not_run == [3.0, 4.0] and opposite.verdict == "undetermined"
    assert [r.holds for r in opposite.settings] == [True, None, None]
    assert ordering.range["roman"] == pytest.approx((0.28, 0.28))
    assert paper_preset.verdict([True, False], 2) == "some"  # disagreement is known whatever was not run
    assert paper_preset.verdict([False, False], 0) == "none" and paper_preset.verdict([True], 0) == "every"


def _legacy(tmp_path, with_metrics=True):
    """A folder from before the counts: bare recalls in the state, one prediction run at the fitted severity."""
    fit_paper_preset(tmp_path, COUNTED, Counted())
    predict_paper_preset(tmp_path, run=Counted(), run_missing=False)
    state = json.loads((tmp_path / "fit_state.json").read_text())
    del state["counts"], state["predicted"]  # bare recalls only, as the state files of that time
    (tmp_path / "fit_state.json").write_text(json.dumps(state))
    old = {"severity": 3.0, "scenario": "opposite_direction", "max_recall": {"roman": 0.24}, "claims": []}
    (tmp_path / "paper_predictions.json").write_text(json.dumps(old))

    def metrics(run, counts):
        (run).mkdir(parents=True, exist_ok=True)
        methods = {m: {"inter": {"max_hits": h, "n_relevant": n}} for m, (h, n) in counts.items()}
        (run / "metrics.json").write_text(json.dumps({"methods": methods}))

    if with_metrics:
        for s, h in Counted.SAME.items():
            metrics(tmp_path / "runs" / f"same_direction_{s:.6f}", {"roman": (h, 50)})
        opp = dict(zip(("roman", "ransac1m", "clipper"), Counted.OPPOSITE[3.0]))
        metrics(tmp_path / "runs" / "opposite_direction", {m: (h, 50) for m, h in opp.items()})


def test_a_folder_from_before_the_counts_is_read_through_its_runs(tmp_path):
    _legacy(tmp_path)
    with pytest.raises(RecordError, match="made before the predictions carried the fit's uncertainty"):
        paper_preset.read_predictions(tmp_path / "paper_predictions.json")
    res = predict_paper_preset(tmp_path, run=Counted(interrupt_at=0), run_missing=False)
    assert res.admitted.severities == [2.0, 3.0, 4.0]
    fitted = next(st for st in res.settings if st.fitted)
    assert fitted.run == "runs/opposite_direction" and fitted.max_recall["roman"].hits == 12
    assert [st.run for st in res.settings] == [None, "runs/opposite_direction", None]
    assert res.claims[1].verdict == "undetermined" and res.claims[1].holds_for == [3.0]


def test_a_folder_from_before_the_counts_without_its_runs_says_so(tmp_path):
    _legacy(tmp_path, with_metrics=False)
    with pytest.raises(ConfigError, match=r"runs\.0\.000000\.roman: saved without hit and relevant-pair counts"):
        predict_paper_preset(tmp_path, run=Counted(interrupt_at=0), run_missing=False)


@pytest.mark.parametrize(
    ("data", "field"),
    [({"grid": []}, "grid"), ({"grid": [1.0]}, "grid"), ({"refine": -1}, "refine"), ({"target": 0}, "target")],
)
def test_a_bad_configuration_is_one_line_naming_the_field(data, field):
    with pytest.raises(ConfigError) as err:
        validate_model(PaperFitConfig, data, source="paper-preset fit")
    assert field in str(err.value) and "\n" not in str(err.value)


def test_commands(tmp_path, monkeypatch):
    monkeypatch.setattr(paper_preset, "default_run", Stub())
    from roman_sim.cli import app

    runner = CliRunner()
    out = tmp_path / "fit"
    res = runner.invoke(app, ["paper-preset", "fit", "--out", str(out), "--grid", "0,1,2,3", "--refine", "1"])
    assert res.exit_code == 0, res.output
    assert "fitted" in res.output and (out / "paper_fit.yaml").is_file()
    assert "admitted" in res.output
    res = runner.invoke(app, ["paper-preset", "predict", "--out", str(out), "--no-run"])
    assert res.exit_code == 0, res.output
    pred = json.loads((out / "paper_predictions.json").read_text())
    assert [c["verdict"] for c in pred["claims"]] == ["undetermined"] * 3 and "undetermined" in res.output
    res = runner.invoke(app, ["paper-preset", "predict", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert (out / "paper_predictions.json").is_file() and "held-out predictions" in res.output
    for args, msg in (
        (["paper-preset", "fit", "--out", str(out), "--grid", "1,a"], "--grid"),
        (["paper-preset", "fit", "--out", str(tmp_path / "empty"), "--grid", ","], "grid"),
        (["paper-preset", "fit", "--out", str(out), "--grid", "2,1"], "grid"),
        (["paper-preset", "predict", "--out", str(tmp_path / "none")], "run the fit first"),
    ):
        res = runner.invoke(app, args)
        assert res.exit_code == 1 and msg in res.output and res.output.count("\n") == 1, res.output


def test_severity_scales_the_error_parameters_when_built():
    fe = validate_model(FrontEndConfig, {"preset": "paper", "severity": 2.0})
    seg = build_segmenter(fe).cfg
    assert seg.undersegment_prob == pytest.approx(0.8) and seg.view_split_frac == pytest.approx(0.5)
    assert seg.partial_frac == pytest.approx(0.5) and seg.merge_gap_px == 3.0  # not a rate: unchanged
    conf = fe.semantics.confusion
    assert build_encoder(fe).cfg.confusion.level == pytest.approx(min(2.0, conf.max_level()))
    assert fe.segmenter.params["undersegment_prob"] == 0.4  # the configuration stays as written
    assert validate_model(FrontEndConfig, fe.model_dump(mode="json")) == fe  # a resolved scenario reloads unchanged
    capped = build_segmenter(validate_model(FrontEndConfig, {"preset": "paper", "severity": 4.0})).cfg
    assert capped.undersegment_prob == 1.0
    # The scenario's own keys override the preset's; another segmenter replaces the preset's entry.
    own = validate_model(FrontEndConfig, {"preset": "paper", "segmenter": {"params": {"undersegment_prob": 0.1}}})
    assert own.segmenter.params["undersegment_prob"] == 0.1 and own.segmenter.params["view_split_frac"] == 0.25
    assert validate_model(FrontEndConfig, {"preset": "paper", "segmenter": "perfect"}).segmenter.params == {}
    assert (
        validate_model(
            FrontEndConfig, {"preset": "paper", "semantics": {"confusion": 0.5}}
        ).semantics.confusion.other.std
        == 0.075
    )


def test_bad_presets(tmp_path):
    with pytest.raises(ConfigError, match=r"unknown preset 'nope' \(valid: paper"):
        validate_model(FrontEndConfig, {"preset": "nope"})
    bad = tmp_path / "bad.yaml"
    bad.write_text("frontend: {}\nextra: 1\n")
    with pytest.raises(ConfigError, match="unknown top-level keys"):
        validate_model(FrontEndConfig, {"preset": str(bad)})
    with pytest.raises(ConfigError, match="file not found"):
        validate_model(FrontEndConfig, {"preset": str(tmp_path / "missing.yaml")})
    with pytest.raises(ConfigError, match="severity"):
        validate_model(FrontEndConfig, {"preset": "paper", "severity": -1})
