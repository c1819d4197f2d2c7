"""Calibration: the simulated front end fitted to a measured one, tested against itself."""

import json

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.config import validate_model
from roman_sim.mapping.calibrate import fit_semantics
from roman_sim.mapping.frontend import FrontEnd
from roman_sim.mapping.semantics import SemanticConfig, expected_cosine, family_cosine
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.studies.calibration import calibrate, render_calibration_frames

TRUE = SemanticConfig(instance_weight=0.12, view_weight=0.15, noise_energy=0.1, common_weight=0.2, group_weight=0.3)
SEG = {"miss_prob": 0.1, "miss_far_prob": 0.3, "oversegment_prob": 0.3, "spurious_rate": 1.0, "boundary_noise_px": 1}


def _grades_of(cfg):
    """Descriptor grades as the grader reports them, filled with the model's expected cosines."""
    edges = list(np.arange(0.0, 181.0, 15.0))
    mids = np.radians(0.5 * (np.array(edges[:-1]) + np.array(edges[1:])))

    def cls(m):
        return {"pairs": 10, "mean": m}

    return {
        "classes": {
            "same_instance": cls(None),
            "same_family": cls(expected_cosine(cfg, False)),
            "same_group": cls(expected_cosine(cfg, False, 0, family_cosine(cfg, "conifer", "deciduous"))),
            "other_group": cls(expected_cosine(cfg, False, 0, family_cosine(cfg, "conifer", "rock"))),
        },
        "view_edges_deg": edges,
        "view_mean": [expected_cosine(cfg, True, d) for d in mids],
        "view_pairs": [10] * len(mids),
    }


def test_fit_inverts_the_expected_cosines_exactly():
    fit = fit_semantics(_grades_of(TRUE))
    for k in ("instance_weight", "view_weight", "noise_energy", "common_weight", "group_weight"):
        assert getattr(fit, k) == pytest.approx(getattr(TRUE, k), abs=1e-9), k
    # Without pairs of other instances the prior's values stay.
    g = _grades_of(TRUE)
    for k in ("same_family", "same_group", "other_group"):
        g["classes"][k] = {"pairs": 0, "mean": None}
    prior = SemanticConfig(instance_weight=0.3, common_weight=0.1)
    fit = fit_semantics(g, prior)
    assert fit.view_weight == pytest.approx(TRUE.view_weight) and fit.instance_weight == prior.instance_weight


@pytest.fixture(scope="module")
def calibrated():
    sc = load_scenario("smoke")
    data = render_calibration_frames(sc, max_frames=60)
    fe = FrontEnd(segmenter={"name": "fastsam", "params": SEG}, encoder="simulated", semantics=TRUE)
    return calibrate(data, fe)


def test_self_calibration_recovers_the_semantic_parameters(calibrated):
    """Rendered smoke world, 60 frames, two robots driving the loop both ways.

    Tolerances: 0.02 on the instance, view and noise terms (sampling of a few hundred
    pairs), 0.06 on the family terms (cos(p_f, p_g) of the world's few family pairs deviates
    from its expectation by the random parts of the 768-d prototypes).
    """
    fit = calibrated.semantics
    assert fit.instance_weight == pytest.approx(TRUE.instance_weight, abs=0.02)
    assert fit.view_weight == pytest.approx(TRUE.view_weight, abs=0.02)
    assert fit.noise_energy == pytest.approx(TRUE.noise_energy, abs=0.02)
    assert fit.common_weight == pytest.approx(TRUE.common_weight, abs=0.06)
    assert fit.group_weight == pytest.approx(TRUE.group_weight, abs=0.06)
    m, f = calibrated.measured_descriptors.classes, calibrated.fitted_descriptors.classes
    for k in m:
        if m[k].pairs:
            assert f[k].mean == pytest.approx(m[k].mean, abs=0.03), k


def test_self_calibration_reproduces_the_segmentation_rates(calibrated):
    """The fitted fastsam model grades like the target on the same frames (another seed).

    On the smoke world nearly every object view is both small and beyond the depth range,
    so the three miss terms are not separable: the test checks the combined miss
    probability of those views (the model's 1 + small + far features) and the rates.
    """
    m, f, cfg = calibrated.measured_segmentation, calibrated.fitted_segmentation, calibrated.segmenter
    assert f.recall == pytest.approx(m.recall, abs=0.03)
    assert f.precision == pytest.approx(m.precision, abs=0.05)
    assert f.mean_iou == pytest.approx(m.mean_iou, abs=0.03)
    assert f.over_segmented / f.frames == pytest.approx(m.over_segmented / m.frames, abs=0.1)
    assert f.spurious / f.frames == pytest.approx(m.spurious / m.frames, abs=0.2)
    assert cfg.boundary_noise_px == SEG["boundary_noise_px"]
    small = 1.0 - 0.5 * (0.0025 + 0.005) / cfg.small_area_frac  # the populated area bin
    truth = SEG["miss_prob"] + 0.3 * small + SEG["miss_far_prob"]
    assert cfg.miss_prob + cfg.miss_small_prob * small + cfg.miss_far_prob == pytest.approx(truth, abs=0.1)


def test_calibration_yaml_is_a_frontend_section(calibrated):
    data = yaml.safe_load(calibrated.frontend_yaml())
    fe = validate_model(FrontEnd, data["frontend"])
    assert fe.segmenter.name == "fastsam" and fe.semantics == calibrated.semantics
    assert json.loads(json.dumps(calibrated.to_json()))["frontend"]["segmenter"]["name"] == "fastsam"


def test_calibrate_command(tmp_path):
    runner = CliRunner()
    out = tmp_path / "cal.yaml"
    res = runner.invoke(
        app,
        [
            "calibrate",
            "smoke",
            "--encoder",
            "simulated",
            "--frames",
            "12",
            "--out",
            str(out),
            "--grades",
            str(tmp_path / "g.json"),
            "--plot",
            str(tmp_path / "g.png"),
        ],
    )
    assert res.exit_code == 0, res.output
    sc = load_scenario(
        "smoke", [f"frontend.semantics={json.dumps(yaml.safe_load(out.read_text())['frontend']['semantics'])}"]
    )
    assert sc.frontend.semantics.dim == 768
    assert (tmp_path / "g.png").stat().st_size > 0 and "measured_descriptors" in json.loads(
        (tmp_path / "g.json").read_text()
    )
    for args, msg in (
        (["calibrate", "smoke"], "give --encoder and/or --segmenter"),
        (
            ["calibrate", "smoke", "--encoder", "{name: clip, params: {weights: /no/such}}"],
            "frontend.encoder.params.weights: no model folder",
        ),
        (["calibrate", "smoke", "--segmenter", "sam9"], "unknown segmenter 'sam9'"),
    ):
        res = runner.invoke(app, args)
        assert res.exit_code == 1 and msg in res.output and res.output.count("\n") == 1, res.output
