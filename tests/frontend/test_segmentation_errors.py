"""The fastsam error model on rendered frames: the merge rate against its parameter, graded.

Rendered depth has no valid pixel on either side of an occlusion edge (the sensor drops
mixed pixels), so a merge model that asked for valid depth across the shared border never
merged anything; merges now follow the image gap and the objects' median depths.
"""

import numpy as np
import pytest

from roman_sim.evaluation.grader import FrontEndGrader
from roman_sim.frontend.segmenter import SEGMENTERS, SegmenterConfig, SimulatedSegmenter


@pytest.fixture(scope="module")
def smoke_frames():
    """80 rendered depth frames (160 x 120) of the smoke world's road, and the world's families."""
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.sim.source import robot_sources
    from roman_sim.world import generate

    sc = load_scenario("smoke")
    world = generate(sc.world.spec(), sc.seed)
    cfg = sc.robots[0].model_copy(update={"max_duration_s": 13.0})
    frames = list(robot_sources(world, [cfg], sc.seed)[0].frames())
    return frames, {o.id: o.family for o in world.truth.objects}


def _seg(**kw):
    base = SEGMENTERS.get("fastsam").model_dump()
    base.update(kw)
    return SimulatedSegmenter(SegmenterConfig(**base), seed=0)


@pytest.mark.parametrize("prob", [0.2, 0.6])
def test_merge_rate_follows_its_parameter(smoke_frames, prob):
    """Merged pairs over all frames and three robot streams against the sum of the model's probabilities.

    The count is a sum of independent Bernoulli draws: within 3 standard deviations of its mean.
    """
    frames, _ = smoke_frames
    seg = _seg(undersegment_prob=prob)
    expected = var = merged = 0.0
    candidates = 0
    for robot in ("a", "b", "c"):
        for f in frames:
            f.robot = robot
            c = seg.merge_candidates(f)
            p = np.array([x[2] for x in c])
            candidates += len(c)
            expected += p.sum()
            var += (p * (1 - p)).sum()
            seg.segment(f)
            merged += len(seg.last_merges)
            assert set(seg.last_merges) <= {(a, b) for a, b, _ in c}
    for f in frames:
        f.robot = "a"
    assert candidates > 300, "the rendered frames hold neighbouring objects"
    assert np.max(p, initial=0.0) <= prob
    assert abs(merged - expected) <= 3 * np.sqrt(var) + 1
    # Each candidate's probability is the parameter times the gap terms: the rate scales with it.
    half = _seg(undersegment_prob=prob / 2).merge_candidates(frames[-1])
    assert [x[2] for x in half] == pytest.approx([x[2] / 2 for x in seg.merge_candidates(frames[-1])])


def test_graded_runs_see_under_segmentation(smoke_frames):
    frames, families = smoke_frames
    graded = {}
    for prob in (0.0, 0.6):
        g = FrontEndGrader(families)
        seg = _seg(undersegment_prob=prob)
        for f in frames:
            g.add(f, seg.segment(f), [])
        graded[prob] = g.seg
    assert graded[0.0].under_segmented == 0 and graded[0.0].touching_pairs > 50
    assert graded[0.6].under_segmented >= 10
    assert graded[0.6].touching_pairs == graded[0.0].touching_pairs  # a property of the truth, not of the masks
