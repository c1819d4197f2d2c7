"""Simulated encoder: unit vectors, determinism, and the cosine distribution of each relation.

The pinned distributions come from 1000 independent pairs per relation (fresh objects,
families and groups each time; seeded, so the same numbers on every machine). Tolerances:
means and spreads within 0.01. The sampling error of a mean is spread / sqrt(1000) <= 0.004,
of a spread about spread / sqrt(2000) <= 0.003; the full-dimensional parts add cross terms
of independent 768-d vectors, a spread of at most 0.017 (level 0) in quadrature, which moves
a spread of 0.075 by 0.002.
"""

import math

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.frontend.components import FrontEndConfig
from roman_sim.frontend.confusion import ConfusionConfig, realisable, relation_moments
from roman_sim.frontend.semantics import SemanticConfig, SimulatedEncoder
from roman_sim.frontend.semantics_stats import CASES, cosine_statistics, sample_cosines, view_curve
from roman_sim.mapping.protocols import EncodeContext, SemanticEncoder

M = np.ones((2, 2), bool)
N_DRAWS = 1000


def test_unit_float32_and_deterministic():
    a = SimulatedEncoder(SemanticConfig(dim=64), seed=3, families={0: "rock"})
    b = SimulatedEncoder(SemanticConfig(dim=64), seed=3, families={0: "rock"})
    va = a.encode(None, M, EncodeContext(0))
    assert va.dtype == np.float32 and va.shape == (64,)
    assert np.linalg.norm(va) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_array_equal(va, b.encode(None, M, EncodeContext(0)))
    assert isinstance(a, SemanticEncoder)
    assert a.family_of(EncodeContext(0)) == "rock" and a.family_of(EncodeContext(-1)) == "terrain"
    # Robots share every vector but their observation noise.
    c = SimulatedEncoder(SemanticConfig(dim=64), seed=3, families={0: "rock"}, robot="b")
    assert not np.array_equal(va, c.encode(None, M, EncodeContext(0)))
    np.testing.assert_array_equal(a.static(0, "rock"), c.static(0, "rock"))


def _case_moments(cfg, case):
    relation, dview = CASES[case]
    return relation_moments(cfg.confusion, math.radians(dview))[relation]


@pytest.mark.parametrize(
    "cfg",
    [
        SemanticConfig(),
        SemanticConfig(
            confusion={
                "same_instance": {"mean_same_view": 0.85, "mean_opposite_view": 0.65, "std": 0.06},
                "same_family": {"mean": 0.65, "std": 0.07},
                "same_group": {"mean": 0.55, "std": 0.09},
                "other": {"mean": 0.3, "std": 0.12},
            }
        ),
    ],
    ids=["default", "wide"],
)
def test_cosine_distribution_per_relation_is_pinned(cfg):
    for case in ("same_view", "opposite_view", "same_family", "same_group", "other"):
        c = sample_cosines(cfg, case, N_DRAWS, seed=1)
        mean, std = _case_moments(cfg, case)
        assert c.mean() == pytest.approx(mean, abs=0.01), case
        assert c.std() == pytest.approx(std, abs=0.01), case


def test_level_scales_the_spreads_and_zero_separates_the_classes():
    for level, want in ((0.0, 0.0), (0.5, 0.5 * 0.075)):
        cfg = SemanticConfig(confusion=level)  # a bare number is the level
        c = sample_cosines(cfg, "other", 600, seed=2)
        assert cfg.confusion.level == level
        # Level 0 keeps only the cross terms of the full-dimensional parts (spread < 0.02).
        assert c.mean() == pytest.approx(0.58, abs=0.01) and c.std() == pytest.approx(want, abs=0.02)
    # At level 0, classes do not overlap: every other-group cosine lies below every same-view one.
    cfg = SemanticConfig(confusion=0.0)
    assert sample_cosines(cfg, "other", 300, 3).max() < sample_cosines(cfg, "same_family", 300, 3).min()


def test_default_overlap_against_clip_gate():
    stats = cosine_statistics(n=400, seed=2)
    assert stats["same_view"]["frac_above"] > 0.9
    assert 0.01 < stats["opposite_view"]["frac_above"] < 0.3  # opposite views mostly fail the 0.85 gate
    assert 0.01 < stats["same_family"]["frac_above"] < 0.2  # other instances of the family sometimes pass
    assert stats["same_group"]["mean"] > stats["other"]["mean"] + 0.05
    degs, means = view_curve(n=20, steps=7)
    assert np.all(np.diff(means) < 0.01) and means[0] - means[-1] > 0.1


def test_bad_confusion_fails_with_the_field():
    cases = [
        ({"other": {"mean": 1.5, "std": 0.1}}, "other.mean"),
        ({"same_family": {"mean": 0.7, "std": -0.1}}, "same_family.std"),
        ({"same_instance": {"mean_same_view": -1.2}}, "mean_same_view"),
        ({"level": -1}, "level"),
        ({"other": {"mean": 0.75, "std": 0.08}}, "other.mean"),  # above same_group.mean
        ({"same_group": {"mean": 0.7, "std": 0.01}}, "same_group.std"),  # below the narrower spread
        ({"same_instance": {"std": 0.2}}, "same_instance.std"),  # more than the noise share allows
        ({"level": 3}, "level"),
    ]
    for conf, field in cases:
        with pytest.raises(ConfigError, match=field) as err:
            validate_model(FrontEndConfig, {"semantics": {"confusion": conf}}, source="frontend")
        assert "\n" not in str(err.value)
    with pytest.raises(ConfigError, match="dim"):
        validate_model(SemanticConfig, {"dim": 2})
    with pytest.raises(ConfigError, match="view_dir"):
        SimulatedEncoder().encode(None, M, EncodeContext(0, view_dir=np.array([np.nan, 0, 0])))


def test_max_level_and_realisable():
    cfg = ConfusionConfig()
    top = cfg.max_level()
    assert 1.0 < top < 2.0
    ConfusionConfig(level=top * 0.999)
    with pytest.raises(ValueError, match="level"):
        ConfusionConfig(level=top * 1.01)
    fixed, notes = realisable(
        0.9, 0.95, 0.5, {"same_family": (0.95, 0.01), "same_group": (0.6, 0.0), "other": (0.7, 0.2)}
    )
    assert fixed.same_instance.mean_opposite_view == 0.9 and fixed.same_family.mean == 0.9
    assert fixed.other.mean == 0.6 and fixed.same_instance.std < 0.1 / math.sqrt(3)
    assert len(notes) >= 5


def test_view_dependence_off_keeps_the_descriptor_whatever_the_view():
    def encode(cfg, view):
        enc = SimulatedEncoder(cfg, seed=5, families={0: "bench"}, robot="a")  # same noise stream each time
        return enc.encode(None, M, EncodeContext(0, view_dir=np.array(view)))

    on, off = SemanticConfig(), SemanticConfig(view_dependence=False)
    assert float(encode(on, [1.0, 0, 0]) @ encode(on, [-1.0, 0, 0])) < 0.9
    np.testing.assert_array_equal(encode(off, [1.0, 0, 0]), encode(off, [-1.0, 0, 0]))


# -- a mask over several objects -----------------------------------------------------------------
def _mean_cos(enc: SimulatedEncoder, ctx: EncodeContext, ref: np.ndarray, n: int = 200) -> float:
    return float(np.mean([enc.encode(None, M, ctx) @ ref for _ in range(n)]))


def test_a_merged_mask_is_described_by_its_pixels_not_its_majority_object():
    """A mask over a rock (60 % of its pixels) and a conifer (40 %): its descriptor lies near both, nearer the
    rock, where the majority rule gave the rock's alone; a 5 % sliver of the conifer stays the rock's."""
    fams = {0: "rock", 1: "conifer"}
    view = np.array([1.0, 0.0, 0.0])
    enc = SimulatedEncoder(SemanticConfig(dim=256), seed=4, families=fams)
    rock, conifer = (enc.encode(None, M, EncodeContext(i, view_dir=view)) for i in (0, 1))
    merged = EncodeContext(0, view_dir=view, shares=((-1, 0.1), (0, 0.54), (1, 0.36)))
    to_rock, to_conifer = _mean_cos(enc, merged, rock), _mean_cos(enc, merged, conifer)
    alone_to_conifer = _mean_cos(enc, EncodeContext(0, view_dir=view), conifer)
    assert to_rock > to_conifer > alone_to_conifer + 0.1, (to_rock, to_conifer, alone_to_conifer)
    # pixel shares weigh the parts: the conifer's share up, its cosine up
    more = EncodeContext(0, view_dir=view, shares=((0, 0.5), (1, 0.5)))
    assert _mean_cos(enc, more, conifer) > to_conifer
    # below merged_min_share (10 % of the object pixels) an object is a sliver: the majority's alone
    a, b = (SimulatedEncoder(SemanticConfig(dim=256), seed=4, families=fams) for _ in range(2))
    sliver = EncodeContext(0, view_dir=view, shares=((0, 0.95), (1, 0.05)))
    np.testing.assert_array_equal(a.encode(None, M, sliver), b.encode(None, M, EncodeContext(0, view_dir=view)))
    parts = a.merged(merged)
    assert a.merged(sliver) is None and parts is not None and [i for i, _ in parts] == [0, 1]
    assert [w for _, w in parts] == pytest.approx([0.6, 0.4], abs=1e-12)


def test_merged_min_share_one_keeps_the_majority_rule_and_one_object_is_unchanged():
    fams = {0: "rock", 1: "conifer"}
    view = np.array([0.0, 1.0, 0.0])
    merged = EncodeContext(0, view_dir=view, shares=((0, 0.6), (1, 0.4)))
    a = SimulatedEncoder(SemanticConfig(dim=64, merged_min_share=1.0), seed=2, families=fams)
    b = SimulatedEncoder(SemanticConfig(dim=64), seed=2, families=fams)
    np.testing.assert_array_equal(a.encode(None, M, merged), b.encode(None, M, EncodeContext(0, view_dir=view)))
    c, d = (SimulatedEncoder(SemanticConfig(dim=64), seed=2, families=fams) for _ in range(2))
    single = EncodeContext(1, view_dir=view, shares=((-1, 0.3), (1, 0.7)))
    np.testing.assert_array_equal(c.encode(None, M, single), d.encode(None, M, EncodeContext(1, view_dir=view)))
    # a sequence's object table names the family: its masks keep that family's description
    e, f = (SimulatedEncoder(SemanticConfig(dim=64), seed=2, families=fams) for _ in range(2))
    named = EncodeContext(0, family="rock", view_dir=view, shares=((0, 0.6), (1, 0.4)))
    np.testing.assert_array_equal(
        e.encode(None, M, named), f.encode(None, M, EncodeContext(0, family="rock", view_dir=view))
    )
