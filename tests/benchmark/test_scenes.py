"""The crossing generator and the suites: headings, drives, overrides, determinism, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.benchmark.plan import relevant_per_bin
from roman_sim.benchmark.scenes import CrossingScene, build_crossing, drive_ends, headings_deg
from roman_sim.benchmark.suites import SUITES, BenchmarkSuite, check_methods, load_suite
from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError

TINY = CrossingScene(
    robots=3, length_m=24.0, site_radius_m=2.0, extent_m=40.0, render_rgb=False, image_width=160, image_height=120
)


def test_headings_are_stratified_over_the_circle_with_seeded_jitter():
    scene = TINY.model_copy(update={"robots": 12})
    h = headings_deg(scene, 3)
    assert np.all((h >= 0) & (h < 360))
    # one heading per 30 deg stratum, after removing the common rotation
    offsets = np.sort((h - h[0]) % 360.0)
    assert np.all(np.diff(offsets) < 60.0) and len(np.unique(np.floor(((h - h[0]) % 360) / 30.0))) >= 6
    np.testing.assert_array_equal(h, headings_deg(scene, 3))
    assert not np.allclose(h, headings_deg(scene, 4))


def test_every_drive_passes_through_the_site_at_its_heading():
    for attempt in range(3):
        ends = drive_ends(TINY, 0, 1, 30.0, attempt)
        mid, d = ends.mean(axis=0), ends[1] - ends[0]
        assert np.linalg.norm(mid) <= TINY.site_radius_m + 1e-9
        assert np.linalg.norm(d) == pytest.approx(TINY.length_m)
        assert np.degrees(np.arctan2(d[1], d[0])) == pytest.approx(30.0)


def test_build_is_deterministic_and_applies_overrides():
    scene = TINY.model_copy(
        update={"overrides": ["robots.0.speed_mps=0.8", "world.overrides.appearance.lighting=noon"]}
    )
    a, b = build_crossing(scene, 0), build_crossing(scene, 0)
    assert a.scenario.model_dump() == b.scenario.model_dump()
    assert [(t.a, t.b, t.relevant, t.heading_diff_deg) for t in a.truths] == [
        (t.a, t.b, t.relevant, t.heading_diff_deg) for t in b.truths
    ]
    sc = a.scenario
    assert [r.name for r in sc.robots] == ["r00", "r01", "r02"] and sc.robots[0].speed_mps == 0.8
    assert sc.world.overrides["ambiguity"] == 0.0 and sc.world.overrides["appearance.lighting"] == "noon"
    assert all(r.path.kind == "waypoints" and r.drift == "typical" for r in sc.robots)
    assert a.trajectory_km > 3 * TINY.length_m / 1000 * 0.95  # routed drives are at least as long as planned
    assert sum(relevant_per_bin(a.truths, [0, 90, 180])) == sum(1 for t in a.truths if t.kind == "inter" and t.relevant)


def test_bad_scenes_and_overrides_name_the_field():
    with pytest.raises(ConfigError, match="extent_m: 40 m is too small for drives of 60 m"):
        validate_model(CrossingScene, {**TINY.model_dump(), "length_m": 60.0})
    with pytest.raises(ConfigError, match="drift: unknown preset 'wobbly'"):
        validate_model(CrossingScene, {**TINY.model_dump(), "drift": "wobbly"})
    with pytest.raises(ConfigError, match="robots.0.speed_mps"):
        build_crossing(TINY.model_copy(update={"overrides": ["robots.0.speed_mps=-1"]}), 0)


def test_suites_by_name_or_file_and_their_errors(tmp_path):
    assert set(SUITES.names()) == {"quick", "standard", "envelope"}
    std = load_suite("standard")
    assert std.heading_edges() == [0, 60, 120, 180] and std.min_relevant_per_bin == 100
    assert [std.worlds_needed(lv) for lv in std.levels] == [22, 20, 16, 12, 8] and std.max_seeds == 40
    assert list(std.levels) == ["low", "mild", "moderate", "medium", "high"]
    with pytest.raises(ConfigError, match=r"unknown benchmark suite 'huge' \(valid: envelope, quick, standard, or a"):
        load_suite("huge")
    with pytest.raises(ConfigError, match="benchmark suite 'nope.yaml': no such file"):
        load_suite("nope.yaml")
    f = tmp_path / "mine.yaml"
    f.write_text("name: mine\nlevels: {flat: 0.0}\nscene: {robots: 4}\nmethods: [roman]\nbogus: 1\n")
    with pytest.raises(ConfigError, match="bogus"):
        load_suite(f)
    f.write_text("name: mine\nlevels: {flat: 0.0}\nscene: {robots: 4}\nmethods: [roman]\nheading_bin_deg: 50\n")
    with pytest.raises(ConfigError, match="heading_bin_deg: must divide 180"):
        load_suite(f)
    with pytest.raises(ConfigError, match=r"levels.flat: the ambiguity knob lies in \[0, 1\]"):
        validate_model(BenchmarkSuite, {"name": "x", "levels": {"flat": 1.5}})
    scene = std.scene_at("high", ["roman"], ["robots.0.speed_mps=0.5"])
    assert (scene.ambiguity, scene.methods, scene.overrides) == (0.952, ["roman"], ["robots.0.speed_mps=0.5"])


def test_methods_are_checked_before_anything_runs():
    assert check_methods(["roman", "examples.mutual_nn_aligner:MutualNNAligner"])[0] == "roman"
    with pytest.raises(ConfigError, match=r"--methods: unknown method 'romann' \(valid: clipper, "):
        check_methods(["romann"])
    with pytest.raises(ConfigError, match="cannot import 'no_such_pkg.mod'"):
        check_methods(["no_such_pkg.mod:Aligner"])
    with pytest.raises(ConfigError, match="--methods: roman given twice"):
        check_methods(["roman", "roman"])


def test_bad_world_counts_name_the_field():
    with pytest.raises(ConfigError, match=r"min_worlds: a count from 1 to max_seeds \(12\), got 20"):
        validate_model(BenchmarkSuite, {"name": "x", "min_worlds": 20})
    with pytest.raises(ConfigError, match=r"min_worlds: a count from 1 to max_seeds \(12\), got 0"):
        validate_model(BenchmarkSuite, {"name": "x", "min_worlds": 0})
    with pytest.raises(ConfigError, match=r"min_worlds.high: a count from 1 to max_seeds \(12\), got 30"):
        validate_model(BenchmarkSuite, {"name": "x", "min_worlds": {"low": 3, "high": 30}})
    with pytest.raises(ConfigError, match=r"min_worlds: unknown level 'hgih' \(levels: low, medium, high\)"):
        validate_model(BenchmarkSuite, {"name": "x", "min_worlds": {"hgih": 3}})
    with pytest.raises(ConfigError, match="min_worlds"):
        validate_model(BenchmarkSuite, {"name": "x", "min_worlds": "many"})
    ok = validate_model(BenchmarkSuite, {"name": "x", "min_worlds": {"low": 20, "high": 2}, "max_seeds": 20})
    assert [ok.worlds_needed(lv) for lv in ok.levels] == [20, 1, 2]
    assert ok.adds_seeds and not validate_model(BenchmarkSuite, {"name": "x"}).adds_seeds


@pytest.mark.parametrize(
    ("spec", "worlds"),
    [
        # 4 relevant pairs per bin and seed at "dense", 2 at "sparse": 10 per bin needs 3 and 5 seeds
        ({"min_relevant_per_bin": 10}, {"dense": 3, "sparse": 5}),
        ({"min_relevant_per_bin": 10, "min_worlds": 4}, {"dense": 4, "sparse": 5}),
        ({"min_worlds": 4}, {"dense": 4, "sparse": 4}),
        ({"min_worlds": {"dense": 6, "sparse": 2}}, {"dense": 6, "sparse": 2}),
        ({"min_relevant_per_bin": 10, "min_worlds": {"sparse": 2}}, {"dense": 3, "sparse": 5}),
        ({"min_relevant_per_bin": 10, "min_worlds": {"dense": 7}, "max_seeds": 6}, None),
        ({"min_relevant_per_bin": 10, "max_seeds": 4}, {"dense": 3, "sparse": 4}),
        ({"seeds": [3, 7]}, {"dense": 2, "sparse": 2}),
    ],
)
def test_the_planner_adds_seeds_until_the_level_has_its_worlds_and_pairs(
    tmp_path, monkeypatch, spec: dict, worlds: dict | None
):
    from roman_sim.benchmark import run
    from roman_sim.benchmark.cells import PlannedCell
    from roman_sim.runner.executors import SerialExecutor

    planned: list[tuple[str, int]] = []

    def fake_plan(scene_json: str, seed: int, name: str, edges: list[float]) -> PlannedCell:
        level = name.split("-")[1]
        planned.append((level, seed))
        per_bin = 4 if level == "dense" else 2
        return PlannedCell(True, scenario={"seed": seed}, relevant=[per_bin] * (len(edges) - 1))

    monkeypatch.setattr(run, "plan_task", fake_plan)
    data = {"name": "x", "levels": {"dense": 0.0, "sparse": 0.5}, "methods": ["roman"], **spec}
    if worlds is None:  # more worlds than max_seeds allows: refused before anything is planned
        with pytest.raises(ConfigError, match=r"min_worlds.dense: a count from 1 to max_seeds \(6\), got 7"):
            validate_model(BenchmarkSuite, data)
        return
    suite = validate_model(BenchmarkSuite, data)
    cells = run.BenchmarkJob(suite, tmp_path).plan(SerialExecutor())
    got = {lv: [c.seed for c in cells if c.level == lv] for lv in suite.levels}
    seeds = spec.get("seeds")
    assert got == {lv: seeds or list(range(n)) for lv, n in worlds.items()}
    assert sorted(planned) == sorted((c.level, c.seed) for c in cells)  # nothing planned beyond what is kept


def test_the_docs_state_how_seeds_are_added():
    from pathlib import Path

    text = " ".join((Path(__file__).resolve().parents[2] / "docs" / "benchmark.md").read_text().split())
    default = BenchmarkSuite(name="x").max_seeds
    assert f"at most `max_seeds` ({default} unless set) per level" in text
    assert "until the level holds `min_worlds` worlds and (with `min_relevant_per_bin`) every heading bin" in text
    suite = validate_model(BenchmarkSuite, {"name": "x", "min_worlds": {"low": 30, "medium": 8}, "max_seeds": 30})
    assert "`min_worlds` is one count for every level or a count per level (`{low: 30, medium: 8}`" in text
    assert [suite.worlds_needed(lv) for lv in ("low", "medium", "high")] == [30, 8, 1]
    assert "a level not named needs one world" in text
