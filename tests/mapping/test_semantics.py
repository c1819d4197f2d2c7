"""Simulated encoder: unit vectors, determinism, and cosine statistics matching the config."""

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.mapping.semantics import (
    EncodeContext,
    SemanticConfig,
    SemanticEncoder,
    SimulatedEncoder,
    expected_cosine,
    family_cosine,
)
from roman_sim.mapping.semantics_stats import CASES, cosine_statistics, view_curve

M = np.ones((2, 2), bool)


def test_unit_float32_and_deterministic():
    a = SimulatedEncoder(SemanticConfig(dim=64), seed=3, families={0: "rock"})
    b = SimulatedEncoder(SemanticConfig(dim=64), seed=3, families={0: "rock"})
    va = a.encode(None, M, EncodeContext(0))
    assert va.dtype == np.float32 and va.shape == (64,)
    assert np.linalg.norm(va) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_array_equal(va, b.encode(None, M, EncodeContext(0)))
    assert isinstance(a, SemanticEncoder)
    assert a.family_of(EncodeContext(0)) == "rock" and a.family_of(EncodeContext(-1)) == "terrain"


@pytest.mark.parametrize(
    "cfg", [SemanticConfig(), SemanticConfig(view_weight=0.2, noise_energy=0.1, instance_weight=0.2)]
)
def test_cosine_statistics_match_configuration(cfg):
    stats = cosine_statistics(cfg, n=60, seed=1)
    for case, (same, dview, fam_b) in CASES.items():
        want = expected_cosine(cfg, same, np.radians(dview), family_cosine(cfg, "conifer", fam_b))
        assert stats[case]["mean"] == pytest.approx(want, abs=0.04), case


def test_default_calibration_against_clip_threshold():
    stats = cosine_statistics(n=100, seed=2)
    assert stats["same_view"]["frac_above"] > 0.95
    assert stats["opposite_view"]["mean"] < 0.85
    assert stats["same_group"]["mean"] > stats["other_group"]["mean"] + 0.2
    degs, means = view_curve(n=20, steps=7)
    assert np.all(np.diff(means) < 0.01) and means[0] - means[-1] > 0.1


def test_bad_config_and_context():
    with pytest.raises(ConfigError, match="common_weight"):
        validate_model(SemanticConfig, {"common_weight": 0.8, "group_weight": 0.5})
    with pytest.raises(ConfigError, match="dim"):
        validate_model(SemanticConfig, {"dim": 2})
    with pytest.raises(ConfigError, match="view_dir"):
        SimulatedEncoder().encode(None, M, EncodeContext(0, view_dir=np.array([np.nan, 0, 0])))
