"""The paper preset: severity scaling, the resumable 1-D fit and the held-out predictions.

The real fit runs whole scenarios; here a stubbed run function stands in for them: its
recall falls linearly with the severity it is given, so the search's result is known.
"""

import json

import pytest
import yaml
from typer.testing import CliRunner

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.frontend.components import FrontEndConfig, build_encoder, build_segmenter
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.studies import paper_preset
from roman_sim.studies.paper_preset import PaperFitConfig, fit_paper_preset, predict_paper_preset, read_predictions


def _severity(overrides):
    return float(next(o for o in overrides if o.startswith("frontend.severity=")).split("=", 1)[1])


class Stub:
    """recall(severity) = 0.95 - 0.2 severity for ROMAN; the opposite direction gives fixed figures."""

    def __init__(self, fail_after=None, opposite=None):
        self.calls = []
        self.fail_after = fail_after
        self.opposite = opposite or {"roman": 0.28, "ransac1m": 0.2, "clipper": 0.1}

    def __call__(self, scenario, overrides, run_dir):
        if self.fail_after is not None and len(self.calls) >= self.fail_after:
            raise KeyboardInterrupt
        self.calls.append((scenario, list(overrides)))
        # Every run's overrides load as a scenario (here on the tiny smoke scenario).
        load_scenario("smoke", [o for o in overrides if o.startswith(("frontend.", "aligners="))])
        if scenario == "opposite_direction":
            return dict(self.opposite)
        s = _severity(overrides)
        return {"roman": 0.95 - 0.2 * s, "clipper": 0.9 - 0.3 * s}


CFG = PaperFitConfig(grid=[0.0, 1.0, 2.0, 3.0], refine=3)


def test_fit_brackets_then_bisects_and_writes_a_preset(tmp_path):
    stub = Stub()
    res = fit_paper_preset(tmp_path, CFG, stub)["fit"]
    # 0.95 - 0.2 s = 0.67 at s = 1.4: grid 0..3, bracket [1, 2], then 1.5, 1.25, 1.375.
    assert [_severity(o) for _, o in stub.calls] == [0.0, 1.0, 2.0, 3.0, 1.5, 1.25, 1.375]
    assert res["severity"] == 1.375 and res["fitted"] == pytest.approx(0.95 - 0.2 * 1.375)
    assert res["paper"] == 0.67 and all(sc == "same_direction" for sc, _ in stub.calls)
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
    assert fit_paper_preset(tmp_path, CFG, rerun)["fit"]["severity"] == 1.375 and rerun.calls == []
    with pytest.raises(ConfigError, match="another fit configuration"):
        fit_paper_preset(tmp_path, CFG.model_copy(update={"refine": 1}), Stub())


def test_fit_without_a_bracket_stops_at_the_grid(tmp_path):
    stub = Stub()
    res = fit_paper_preset(tmp_path, PaperFitConfig(grid=[0.0, 0.5], target=0.5), stub)["fit"]
    assert len(stub.calls) == 2 and res["severity"] == 0.5


def test_predictions_are_claims_that_hold_or_not(tmp_path):
    fit_paper_preset(tmp_path, CFG, Stub())
    stub = Stub()
    res = predict_paper_preset(tmp_path, run=stub)
    ((scenario, overrides),) = stub.calls
    assert scenario == "opposite_direction" and _severity(overrides) == 1.0
    assert "aligners=[roman, ransac1m, clipper]" in overrides
    assert f"frontend.preset={(tmp_path / 'paper_fit.yaml').resolve()}" in overrides
    holds = [c.holds for c in res.claims]
    same = 0.95 - 0.2 * 1.375
    assert holds == [True, True, 0.67 / 0.34 <= same / 0.28 <= 0.67 / 0.18]
    assert res.claims[2].value == pytest.approx(same / 0.28)
    assert read_predictions(tmp_path / "paper_predictions.json") == res
    miss = predict_paper_preset(tmp_path, run=Stub(opposite={"roman": 0.5, "ransac1m": 0.6, "clipper": 0.1}))
    assert [c.holds for c in miss.claims] == [False, False, False]


def test_commands(tmp_path, monkeypatch):
    monkeypatch.setattr(paper_preset, "default_run", Stub())
    from roman_sim.cli import app

    runner = CliRunner()
    out = tmp_path / "fit"
    res = runner.invoke(app, ["paper-preset", "fit", "--out", str(out), "--grid", "0,1,2,3", "--refine", "1"])
    assert res.exit_code == 0, res.output
    assert "fitted" in res.output and (out / "paper_fit.yaml").is_file()
    res = runner.invoke(app, ["paper-preset", "predict", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert (out / "paper_predictions.json").is_file() and "held-out predictions" in res.output
    for args, msg in (
        (["paper-preset", "fit", "--out", str(out), "--grid", "1,a"], "--grid"),
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
