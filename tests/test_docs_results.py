"""The reference results page: its generated block, and every figure of its prose, from committed files.

The block must be exactly what ``results/reference/summary.json`` renders to (that file is
re-derived from the raw data in ``tests/studies/test_reference_claims.py``); the prose's
figures are recomputed here from the committed files and the bundled scenarios.
"""

from __future__ import annotations

import csv
import gzip
import json
import re
import statistics
from pathlib import Path

import pytest
from committed_results import BENCHMARKS_OUT, committed_files
from committed_results import REFERENCE as REF

from roman_sim.pipeline.scenario import load_scenario
from roman_sim.posegraph.types import PoseGraphConfig
from roman_sim.studies import pages
from roman_sim.studies.reference import read_reference

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "results.md"

pytestmark = pytest.mark.skipif(not (REF / "summary.json").is_file(), reason="no committed reference results")


def _text() -> str:
    return PAGE.read_text(encoding="utf-8")


def _flat() -> str:
    return " ".join(_text().split())


def _summary() -> dict:
    return json.loads((REF / "summary.json").read_text(encoding="utf-8"))


def test_results_block_is_rendered_from_the_summary():
    summary = read_reference(REF / "summary.json")
    assert pages.current_block(_text(), pages.RESULTS_MARKERS) == pages.results_block(summary)


def test_page_states_the_committed_size():
    m = re.search(r"([\d.]+) MB in all, ([\d.]+) MB of it the paper-scale runs", _flat())
    assert m, "docs/results.md states the size of the reference results"
    files = committed_files(roots=[REF])
    total = sum(p.stat().st_size for p in files) / 1e6
    big = sum(p.stat().st_size for p in files if p.relative_to(REF).parts[0].startswith("kimera_")) / 1e6
    assert abs(float(m.group(1)) - total) < 0.15 and abs(float(m.group(2)) - big) < 0.15, (total, big)


def test_acceptance_thresholds_are_the_scenarios():
    m = re.search(r"accept closures at the ROS node's k = (\d+); with the paper's k = (\d+)", _flat())
    assert m, "docs/results.md states the acceptance thresholds"
    multi = [load_scenario(f"multi_robot_{env}") for env in ("tunnel", "hybrid", "outdoor")]
    assert {s.posegraph.lc_association_thresh for s in multi} == {int(m.group(1))}
    assert PoseGraphConfig().lc_association_thresh == int(m.group(2))  # the library default is the paper's


def test_paper_scale_runs_are_as_described():
    m = re.search(r"paper-scale `kimera_\*` runs \((\d+(?:\.\d+)?)-(\d+(?:\.\d+)?) km per robot\)", _flat())
    assert m, "docs/results.md states the paper-scale runs' length"
    lo, hi = float(m.group(1)), float(m.group(2))
    listed = re.search(r"Committed paper-scale runs: ((?:`kimera_\w+`(?:, | and )?)+)", _flat())
    assert listed, "docs/results.md names the committed paper-scale runs"
    names = re.findall(r"`(kimera_\w+)`", listed.group(1))
    assert sorted(names) == sorted(p.name for p in REF.glob("kimera_*") if p.is_dir())
    # "their robots render 320 x 240 RGB for the visual method, so Table I has visual and combined rows"
    assert "their robots render 320 x 240 RGB for the visual method" in _flat()
    for name in names:
        stats = json.loads((REF / name / "map_stats.json").read_text(encoding="utf-8"))
        assert lo <= stats["trajectory_km"] / stats["robots"] <= hi, name
        sc = load_scenario(name)
        assert all(r.render_rgb and (r.camera.width, r.camera.height) == (320, 240) for r in sc.robots), name
        assert {"visual", "combined"} <= set(_summary()["runs"][name]["ate"]), name


def test_small_multi_robot_runs_are_as_described():
    m = re.search(r"their robots drive about (\d+)-(\d+) m each", _flat())
    assert m, "docs/results.md states the small multi-robot runs' length"
    lo, hi = int(m.group(1)), int(m.group(2))
    for env in ("tunnel", "hybrid", "outdoor"):
        stats = json.loads((REF / f"multi_robot_{env}" / "map_stats.json").read_text(encoding="utf-8"))
        assert 0.9 * lo <= 1000 * stats["trajectory_km"] / stats["robots"] <= 1.1 * hi, env  # "about"


def _cross_closures(scenario: str, method: str, k: int) -> list[dict[str, str]]:
    """Cross-robot pairs of ``method`` with at least ``k`` associations, read from pairs.csv.gz."""
    with gzip.open(REF / scenario / "pairs.csv.gz", "rt", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return [r for r in rows if r["method"] == method and r["robot_a"] != r["robot_b"] and int(r["n_assoc"]) >= k]


def test_the_hybrid_miss_is_explained_by_the_data():
    page = _flat()
    d = REF / "multi_robot_hybrid"
    ate = _summary()["runs"]["multi_robot_hybrid"]["ate"]
    m = re.search(r"\((\d\.\d\d) against (\d\.\d\d) m over all robots; (\d\.\d\d) m with oracle closures\)", page)
    assert m, "docs/results.md states the hybrid ATEs"
    assert [float(g) for g in m.groups()] == [round(ate[x]["all"], 2) for x in ("roman", "odometry", "oracle")]
    assert ate["roman"]["all"] > ate["odometry"]["all"], "the paragraph explains a miss"
    stats = json.loads((d / "map_stats.json").read_text(encoding="utf-8"))
    m = re.search(r"Its submaps hold (\d+\.\d) segments on average", page)
    assert m and float(m.group(1)) == round(stats["segments_per_submap"], 1)
    k = json.loads((d / "metrics.json").read_text(encoding="utf-8"))["acceptance_k"]
    roman = _cross_closures("multi_robot_hybrid", "roman", k)
    m = re.search(
        r"all (\d+) of ROMAN's cross-robot closures at the acceptance threshold \(k = (\d+)\) are correct "
        r"\(5 deg / 1 m\), but their rotation errors reach (\d\.\d) deg \(median (\d\.\d) deg\) and robot (\w) "
        r"is tied to the others by (\d+) closure alone",
        page,
    )
    assert m, "docs/results.md states ROMAN's hybrid closures"
    rot = sorted(float(r["rot_err_deg"]) for r in roman)
    assert [int(m[1]), int(m[2])] == [len(roman), k]
    assert all(r["correct"] == "true" for r in roman)
    assert [float(m[3]), float(m[4])] == [round(rot[-1], 1), round(float(statistics.median(rot)), 1)]
    tied = [r for r in roman if m[5] in (r["robot_a"], r["robot_b"])]
    assert len(tied) == int(m[6])
    visual = _cross_closures("multi_robot_hybrid", "visual", k)
    m = re.search(
        r"The visual closures there are right in (\d+) of the (\d+) it accepts, but none ties robot (\w)", page
    )
    assert m and [int(m[1]), int(m[2])] == [sum(r["correct"] == "true" for r in visual), len(visual)]
    assert not [r for r in visual if m[3] in (r["robot_a"], r["robot_b"])]


def test_paper_scale_run_times_are_the_committed_timings():
    m = re.search(r"Committed paper-scale runs: (.*?), each (\d+)-(\d+) min with RGB on 2 workers", _flat())
    assert m, "docs/results.md states the committed paper-scale runs and their times"
    runs = sorted(p.name for p in REF.glob("kimera_*") if p.is_dir())
    assert sorted(re.findall(r"`(kimera_\w+)`", m[1])) == runs
    minutes = []
    for run in runs:
        stages = json.loads((REF / run / "timings.json").read_text(encoding="utf-8"))["stages"]
        minutes.append(round(sum(s["seconds"] for s in stages.values()) / 60))
        assert stages["evaluation"]["pairs"]["workers"] == 2
    assert (int(m[2]), int(m[3])) == (min(minutes), max(minutes))
    assert max(minutes) <= 45  # the budget of a paper-scale run with RGB on 2 workers


def test_visual_same_direction_miss_is_the_data():
    """The results page's account of the visual method's same-direction closures: errors from
    the committed pairs tables, inlier geometry from ``visual_inliers.json``."""
    flat = _flat()
    m = re.search(
        r"In `same_direction` the visual method accepts (\d+) cross-robot closures \(at least 5 inliers\), all "
        r"(\d+) at the right place \(true submap centres within 10 m\), yet only (\d+) are correct: the median "
        r"rotation error is (\d+\.\d\d) deg \((\d+) of the \d+ above the 5 deg tolerance\)\. Driven as a replay "
        r"\(`same_direction_replay`\) it accepts (\d+), (\d+) of them correct, median rotation error (\d+\.\d\d) deg",
        flat,
    )
    assert m, "docs/results.md no longer explains the visual same-direction figures"

    same, replay = (_cross_closures(s, "visual", 5) for s in ("same_direction", "same_direction_replay"))
    assert all(r["rot_err_deg"] not in ("", "nan") for r in same + replay)  # every accepted one has an estimate
    rot = [float(r["rot_err_deg"]) for r in same]
    assert int(m[1]) == len(same) and int(m[2]) == sum(r["relevant"] == "true" for r in same)
    assert int(m[3]) == sum(r["correct"] == "true" for r in same)
    assert float(m[4]) == round(statistics.median(rot), 2) and int(m[5]) == sum(x > 5 for x in rot)
    assert int(m[6]) == len(replay) and int(m[7]) == sum(r["correct"] == "true" for r in replay)
    assert float(m[8]) == round(statistics.median(float(r["rot_err_deg"]) for r in replay), 2)

    geo = json.loads((BENCHMARKS_OUT / "visual_inliers.json").read_text(encoding="utf-8"))
    m = re.search(
        r"In `same_direction` the inliers are a median of (\d+) points within (\d\.\d\d) m \(RMS\) of their "
        r"centroid, (\d\.\d\d) m from the camera: .*? the true pose keeps a median (\d+) % of the inliers within "
        r"the 0\.3 m threshold too, .*? a median of (\d+) inliers within (\d\.\d\d) m of their centroid, "
        r"(\d\.\d\d) m away",
        flat,
    )
    assert m, "docs/results.md no longer states the inliers' geometry"
    sd, rp = geo["same_direction"], geo["same_direction_replay"]
    assert (int(m[1]), float(m[2]), float(m[3])) == (
        int(sd["median_inliers"]),
        round(sd["median_radius_m"], 2),
        round(sd["median_depth_m"], 2),
    )
    assert int(m[4]) == round(100 * sd["median_true_pose_inlier_share"])
    assert (int(m[5]), float(m[6]), float(m[7])) == (
        int(rp["median_inliers"]),
        round(rp["median_radius_m"], 2),
        round(rp["median_depth_m"], 2),
    )
    # the rows behind the medians
    for entry in (sd, rp):
        rows = entry["rows"]
        assert entry["closures"] == len(rows) and entry["correct"] == sum(r["correct"] for r in rows)
        assert entry["median_radius_m"] == statistics.median(r["radius_m"] for r in rows)
    assert max(r["radius_m"] for r in sd["rows"]) < min(1.0, rp["median_radius_m"])


def _semantics(run: Path) -> dict:
    import yaml

    return yaml.safe_load((run / "config.yaml").read_text(encoding="utf-8"))["frontend"]["semantics"]


def test_every_run_is_made_with_the_current_descriptor_model():
    """The page says every run of the summary, the demo and the sweep uses the appearance-driven
    descriptors, and each such run's resolved configuration has the appearance weights."""
    flat = _flat()
    said = (
        "Every committed run of the summary, the demo's and the ambiguity sweep's, the paper-scale runs and the "
        "`paper` preset's fit included"
    )
    assert said + ", was made with the current simulated descriptors" in flat
    sweep = json.loads((REF / "ambiguity_sweep" / "sweep.json").read_text(encoding="utf-8"))
    runs = (
        [REF / n for n in [*_summary()["runs"], "demo"]]
        + [REF / "ambiguity_sweep" / r["run_id"] for r in sweep["runs"]]
        + sorted((REF / "paper_preset" / "runs").iterdir())
    )
    earlier = [run.relative_to(REF).as_posix() for run in runs if "appearance" not in _semantics(run)]
    assert len(runs) > 28 and earlier == []
    assert "the appearance-driven one sets `frontend.semantics.appearance`" in flat
