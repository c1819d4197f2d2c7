"""The visual method in the pipeline: configuration, keyframes through the stages, and the
seeded orderings of ``visual_small`` (same- and opposite-direction revisits)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from roman_sim.core.errors import ConfigError
from roman_sim.mapping.io import load_keyframes, load_submaps
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.testing import assert_not_worse, assert_recall

SEEDS = [1]  # one seed: a run of visual_small is about 80 s of CPU (seed 0, figures below, passed too)


@pytest.fixture(scope="module", params=SEEDS, ids=[f"seed{s}" for s in SEEDS])
def visual_run(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory):
    sc = load_scenario("visual_small", [f"seed={request.param}"])
    return Experiment(sc, tmp_path_factory.mktemp("visual_small") / f"seed{request.param}").run()


def test_visual_needs_rgb_and_names_the_robot() -> None:
    with pytest.raises(ConfigError, match=r"robots\.1\.render_rgb: robot 'b' must render RGB"):
        load_scenario("visual_small", ["robots.1.render_rgb=false"])
    assert not load_scenario("smoke").uses_visual and load_scenario("visual_small").uses_visual


@pytest.mark.slow
def test_keyframes_flow_through_the_stages(visual_run) -> None:
    d = visual_run.run_dir
    kf = load_keyframes(d / "keyframes" / "a.npz")
    subs = load_submaps(d / "submaps" / "a.npz")
    # every keyframe lands in exactly one submap, with its pose re-expressed in the submap frame
    assert sum(len(s.keyframes) for s in subs) == len(kf) > 20
    s = next(s for s in subs if len(s.keyframes))
    i = int(np.flatnonzero(np.isclose(kf.t, s.keyframes.t[0]))[0])
    np.testing.assert_allclose(s.T_odom_submap @ s.keyframes.T_submap_cam[0], kf.T_submap_cam[i], atol=1e-9)
    ms = visual_run.map_stats
    assert ms.keyframes_per_submap > 3 and ms.keyframe_kb_per_submap > ms.kb_per_submap > 0
    assert ms.keyframe_mb_per_km > 0
    graphs = json.loads((d / "posegraph.json").read_text())
    assert set(graphs) == {"roman", "visual", "combined", "oracle"}
    # the combined graph holds ROMAN's accepted closures and every visual one
    assert graphs["combined"]["closures"] == graphs["roman"]["closures_used"] + graphs["visual"]["closures"]


@pytest.mark.slow
def test_visual_orderings_hold(visual_run) -> None:
    """Visual recall collapses at 120-180 deg where ROMAN holds; it is not zero at 0-60 deg;
    the combined pose graph is at least as good as ROMAN's and better than visual's.

    Measured on seeds 0 and 1 (the suite runs seed 1, where visual's pose graph fails), max recall
    0-60 / 60-120 / 120-180 deg:
    ROMAN 0.92/1.00/0.81, 0.90/0.40/0.74; visual 0.77/0.00/0.00, 0.80/0.20/0.00.
    SE(3) ATE of all robots (m), combined / ROMAN / visual / odometry / oracle:
    0.287/0.308/0.328/0.397/0.276, 0.395/0.406/19.9/0.910/0.284. On seed 1 visual's graph is
    far off because robot c (opposite direction) is tied to the others only by wrong visual
    closures.
    """
    assert_not_worse(visual_run, "roman", "visual", heading_bin="120-180")
    assert visual_run.recall("roman", "120-180") >= visual_run.recall("visual", "120-180") + 0.2
    assert visual_run.recall("visual", "120-180") <= 0.05
    assert_recall(visual_run, "visual", {"0-60": 0.4})
    ate = {v: visual_run.ate.rmse(v, "se3") for v in ("odometry", "roman", "visual", "combined")}
    assert ate["combined"] <= ate["roman"] + 0.02, ate
    assert ate["combined"] < ate["visual"], ate
