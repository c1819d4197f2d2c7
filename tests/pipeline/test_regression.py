"""Ground-truth regression of the seeded smoke run: pinned figures, ordering, determinism."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys

import pytest

from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.testing import assert_ate_below, assert_not_worse, assert_recall, run_folder_bytes

# Figures of `roman-sim run smoke` (seed 0), pinned as integer counts: the run is deterministic, and a
# count within 1 absorbs a pair flipping on another machine's floating point. If a deliberate change moves
# them, re-pin from the run's metrics.json and say why in the commit.
# Definitions changed with the every-pair evaluation: the headline is now cross-robot pairs only (the 2
# relevant same-robot pairs are pinned apart), so the relevant counts are 19 (was 21 mixed) overall and 4
# (was 5) at 60-120 deg; the hits did not change (11, 2, 9 for ROMAN; 7, 2, 5 for CLIPPER).
# Re-pinned when the mask erosion began to follow the image width (3 px at 640 px: 1 px on these
# 160 x 120 frames, where it was 3 px) and the simulated encoder's classes began to overlap: more small
# objects keep pixels after erosion, so 108 segments (was 88) and 340 available associations (was 274);
# ROMAN 13, 3, 10 hits (was 11, 2, 9), CLIPPER 7, 1, 6 (was 7, 2, 5).
# Re-pinned when the simulated encoder's descriptors began to come from each instance's appearance
# (no per-object draw) and its view part from each shape's asymmetry: instances of one family drawn
# alike look alike, so ROMAN selects 215 cross-robot associations (was 211), 120 of them correct (was 119).
# Re-pinned when the camera's pixels became square (87 deg horizontal, 70.9 deg vertical where it was 58 deg)
# and the light term took its measured size (lighting_fall 0.64, was 0.04): the taller view keeps more small
# objects, so 113 segments (was 108) and 335 available associations (was 340); CLIPPER 9, 1, 8 hits (was 7,
# 1, 6) and 110 of 358 selected correct (was 116 of 361); ROMAN's hits unchanged, 125 of 225 selected correct
# (was 120 of 215; 223 with the camera change alone); ROMAN's ATE 0.492 m (was 0.470, within its tolerance).
PINNED_MAP = {"segments": (113, 6), "submaps": (18, 1)}
PINNED_HITS = {  # method -> (pair set, heading bin or None) -> (max hits, relevant pairs)
    "roman": {
        ("inter", None): (13, 19),
        ("inter", "60-120"): (3, 4),
        ("inter", "120-180"): (10, 15),
        ("intra", None): (0, 2),
    },
    "clipper": {
        ("inter", None): (9, 19),
        ("inter", "60-120"): (1, 4),
        ("inter", "120-180"): (8, 15),
        ("intra", None): (0, 2),
    },
}
PINNED_ASSOC = {"roman": (125, 225, 335), "clipper": (110, 358, 335)}  # cross-robot: correct, selected, available
PINNED_ATE = {
    "odometry": (0.535, 0.05),
    "odometry_no_prior": (0.307, 0.05),
    "roman": (0.492, 0.08),
    "oracle": (0.266, 0.08),
}  # SE(3), over the robots every row placed (both)


def test_smoke_pinned_map_figures(smoke_run):
    for key, (value, tol) in PINNED_MAP.items():
        got = getattr(smoke_run.map_stats, key)
        assert abs(got - value) <= tol, f"{key}: {got} vs pinned {value}"
    assert 0 < smoke_run.map_stats.kb_per_submap <= 125


@pytest.mark.parametrize("method", sorted(PINNED_HITS))
def test_smoke_pinned_hits(smoke_run, method):
    for (kind, heading_bin), (hits, relevant) in PINNED_HITS[method].items():
        s = smoke_run.metrics.stats(method, heading_bin, kind)
        assert s.n_relevant == relevant, f"{method} {kind} {heading_bin}: {s.n_relevant} relevant, pinned {relevant}"
        assert abs(s.max_hits - hits) <= 1, f"{method} {kind} {heading_bin}: {s.max_hits} hits vs pinned {hits}"


@pytest.mark.parametrize("method", sorted(PINNED_ASSOC))
def test_smoke_pinned_association_truth(smoke_run, method):
    s = smoke_run.metrics.stats(method, kind="inter")
    correct, selected, available = PINNED_ASSOC[method]
    assert s.assoc_available == available  # depends on the maps only
    assert abs(s.assoc_correct - correct) <= 3 and abs(s.assoc_selected - selected) <= 3


@pytest.mark.parametrize("variant", sorted(PINNED_ATE))
def test_smoke_pinned_ate(smoke_run, variant):
    value, tol = PINNED_ATE[variant]
    got = smoke_run.ate.rmse(variant, "se3")
    assert abs(got - value) <= tol, f"{variant}: {got} vs pinned {value}"
    assert smoke_run.ate.variants[variant].connected == ["a", "b"] and smoke_run.ate.common == ["a", "b"]


def test_opposite_direction_ordering(opposite_run):
    """Whatever the seed: ROMAN >= CLIPPER at 120-180 deg, and its pose graph beats odometry.

    Measured on seeds 0-3 (roman / clipper recall at 120-180 deg; ATE roman / odometry, m):
    0.68/0.57, 0.68/0.46, 0.29/0.25, 0.58/0.32; 0.42/0.48, 0.54/0.77, 0.44/0.45, 0.53/0.67.
    """
    # paired on the same 28 relevant pairs (seed 0: 24 against 21, 1 lost, 4 gained) the bound on the recall
    # ROMAN could lose is 0.16: within a margin of 0.2; a margin of 0.1 would need about 44 pairs
    assert_not_worse(opposite_run, "roman", "clipper", heading_bin="120-180", margin=0.2)
    assert_ate_below(opposite_run, "roman", "odometry")
    assert_recall(opposite_run, "roman", {"120-180": 0.2})


def test_two_fresh_runs_write_the_same_bytes(smoke_run, tmp_path):
    """Another process, another working directory, another PYTHONHASHSEED: the same folder."""
    elsewhere = tmp_path / "cwd"
    elsewhere.mkdir()
    env = {**os.environ, "PYTHONHASHSEED": "12345"}
    code = (
        "from roman_sim.pipeline.experiment import Experiment; from roman_sim.pipeline.scenario import "
        f"load_scenario; Experiment(load_scenario('smoke'), {str(tmp_path / 'again')!r}, fresh=True).run()"
    )
    subprocess.run([sys.executable, "-c", code], cwd=elsewhere, env=env, check=True, timeout=600)
    first, again = run_folder_bytes(smoke_run.run_dir), run_folder_bytes(tmp_path / "again")
    assert sorted(first) == sorted(again)
    differ = [name for name in first if first[name] != again[name]]
    assert not differ, f"files differ between two runs of the same seed: {differ}"


def test_cached_and_fresh_stages_write_the_same_bytes(smoke_run, tmp_path):
    run_dir = tmp_path / "copy"
    shutil.copytree(smoke_run.run_dir, run_dir)
    res = Experiment(load_scenario("smoke"), run_dir, from_stage="evaluation").run()
    assert set(res.reused) == {"maps", "submaps"}
    first, again = run_folder_bytes(smoke_run.run_dir), run_folder_bytes(run_dir)
    assert [n for n in first if first[n] != again.get(n)] == []


def test_other_seed_differs(smoke_run, tmp_path):
    other = Experiment(
        load_scenario("smoke", ["seed=1", "robots.0.max_length_m=15", "robots.1.max_length_m=15"]), tmp_path / "seed1"
    ).run()
    same_len = Experiment(
        load_scenario("smoke", ["robots.0.max_length_m=15", "robots.1.max_length_m=15"]), tmp_path / "seed0"
    ).run()
    assert (other.run_dir / "maps" / "a.npz").read_bytes() != (same_len.run_dir / "maps" / "a.npz").read_bytes()


def test_undefined_metrics_are_none_not_zero(smoke_run):
    for m in smoke_run.metrics.methods.values():
        for ps in m.sets.values():
            for row in ps.heading_bins_fine:
                if row.stats.n_relevant == 0:
                    assert row.stats.max_recall is None and row.stats.recall_ci is None
    ate = smoke_run.summary().ate
    assert ate
    assert not any(isinstance(v, float) and math.isnan(v) for row in ate.values() for v in (row.common, row.all))
