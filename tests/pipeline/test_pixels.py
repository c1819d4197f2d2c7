"""Runs whose front end sees only pixels: no object id or family is read before the evaluation."""

import json

import numpy as np
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.records import to_json
from roman_sim.frontend import image_encoder, image_segmenter, segmenter, semantics
from roman_sim.frontend.confusion import relation_moments
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario

PIXELS = [
    "robots.0.render_rgb=true",
    "robots.1.render_rgb=true",
    "robots.0.max_length_m=25",
    "robots.1.max_length_m=25",
    "frontend.segmenter=image",
    "frontend.encoder=image",
    "world.overrides.appearance={textures: true}",
]


def _never(*args, **kwargs):
    raise AssertionError("a truth-driven front-end component was constructed")


def test_pixels_run_reads_no_truth_before_the_evaluation(tmp_path, monkeypatch):
    monkeypatch.setattr(segmenter.SimulatedSegmenter, "__init__", _never)
    monkeypatch.setattr(semantics.SimulatedEncoder, "__init__", _never)
    seen = {"frames": 0, "contexts": 0}
    segment, encode = image_segmenter.ImageSegmenter.segment, image_encoder.ImageEncoder.encode_batch

    def spy_segment(self, frame):
        assert frame.truth is None and frame.rgb is not None
        seen["frames"] += 1
        masks = segment(self, frame)
        assert all(m.object_ids == () for m in masks)
        return masks

    def spy_encode(self, rgb, masks, contexts):
        assert all(c.object_id is None and c.family is None and c.view_dir is None for c in contexts)
        seen["contexts"] += len(contexts)
        return encode(self, rgb, masks, contexts)

    monkeypatch.setattr(image_segmenter.ImageSegmenter, "segment", spy_segment)
    monkeypatch.setattr(image_encoder.ImageEncoder, "encode_batch", spy_encode)
    sc = load_scenario("smoke", PIXELS)
    assert sc.world.spec().appearance.textures
    res = Experiment(sc, tmp_path / "pixels").run()
    assert seen["frames"] > 100 and seen["contexts"] > 0
    assert res.map_stats.segments > 0
    fe = json.loads((tmp_path / "pixels" / "metrics.json").read_text())["frontend"]
    assert fe["segmenter"] == "image" and fe["encoder"] == "image"
    seg = fe["segmentation"]
    # every mapped frame is graded; the report's snapshot segments one more (drawn, not graded)
    assert seg["frames"] == seen["frames"] - 1 and seg["objects"] > 0 and 0 < seg["recall"] <= 1
    assert fe["descriptors"]["classes"]["same_instance"]["pairs"] > 0
    report = (tmp_path / "pixels" / "report.md").read_text()
    assert "## Front end against truth" in report and "plots/frontend.png" in report
    assert (tmp_path / "pixels" / "plots" / "frontend.png").stat().st_size > 0
    assert to_json(res.metrics.frontend) == fe


def test_truth_driven_run_is_graded_too(smoke_run):
    fe = to_json(smoke_run.metrics.frontend)
    assert fe["segmenter"] == "perfect" and fe["encoder"] == "simulated"
    seg = fe["segmentation"]
    assert seg["precision"] == 1.0 and seg["recall"] == 1.0 and seg["mean_iou"] == 1.0
    d = fe["descriptors"]
    cfg = smoke_run.scenario.frontend.semantics
    for lo, hi, mean, n in zip(d["view_edges_deg"], d["view_edges_deg"][1:], d["view_mean"], d["view_pairs"]):
        if n >= 20:
            # each shape turns with its own measured asymmetry (at most the configured view share), so
            # the mean cosine at the bin's view difference lies between the configured rate and the same view
            want = relation_moments(cfg.confusion, np.radians((lo + hi) / 2))["same_instance"][0]
            same = relation_moments(cfg.confusion, 0.0)["same_instance"][0]
            assert want - 0.02 <= mean <= same + 0.02, (lo, n, mean, want, same)


def test_rgb_front_end_without_rgb_fails_before_any_stage(tmp_path):
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["run", "smoke", "--out", str(out), "--set", "frontend.encoder=image"])
    assert res.exit_code == 1
    line = res.output.strip()
    assert "\n" not in line and "robots.a.render_rgb" in line and "encoder 'image' needs RGB" in line
    assert not (out / "manifest.json").exists()


def test_user_components_without_rgb_are_noted(tmp_path):
    from roman_sim.pipeline.context import RunContext
    from roman_sim.pipeline.stages.maps import _rgb_notes

    sc = load_scenario("smoke", ["frontend.segmenter=examples.depth_segmenter:DepthEdgeSegmenter"])
    notes = _rgb_notes(RunContext(sc, tmp_path))
    assert len(notes) == 2 and "robot a renders no RGB" in notes[0] and "got rgb=None" in notes[0]
    assert _rgb_notes(RunContext(load_scenario("smoke"), tmp_path)) == []
