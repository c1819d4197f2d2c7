"""Every committed result file of a typed kind reads into its record and writes back to the same bytes.

The committed files under the committed result folders (``committed_results``: never a user's
own run folders under ``results/``) are the test: reading one with its checked reader and
writing the record with its writer must give the file's bytes, so moving a file onto the
typed reader and writer changes no committed result. A fresh run writes its files in the same
format. A damaged file fails with one line naming the file and the field.
"""

from __future__ import annotations

import gzip
import json
from collections.abc import Callable
from pathlib import Path

import pytest
from committed_results import REFERENCE, RESULTS, committed_files

from roman_sim.benchmark.board import read_runtimes
from roman_sim.benchmark.board_records import read_leaderboard, write_leaderboard_json
from roman_sim.benchmark.cells import BENCHMARK_SCHEMA, BenchmarkRecord, CellStatus, PlanRecord
from roman_sim.core.records import RecordError, read_record, write_record
from roman_sim.evaluation.atetable import read_ate, write_ate
from roman_sim.evaluation.grades import FrontEndGrades
from roman_sim.evaluation.records import (
    read_alignments,
    read_map_stats,
    read_timings,
    run_timings,
    write_alignments,
    write_map_stats,
    write_timings,
)
from roman_sim.evaluation.results import read_metrics_json, write_metrics_json
from roman_sim.evaluation.variants import GraphInfo
from roman_sim.pipeline.manifest import MANIFEST_SCHEMA, ManifestRecord
from roman_sim.pipeline.sweep_aggregate import SWEEP_SCHEMA, read_sweep_json
from roman_sim.studies.attribution import SCHEMA as ATTRIBUTION_SCHEMA
from roman_sim.studies.attribution import AttributionPlan
from roman_sim.studies.paper_preset import FitStateRecord, read_predictions
from roman_sim.studies.reference import read_reference


def _rewrite_sweep(src: Path, dest: Path) -> None:
    write_record(dest, read_sweep_json(src.parent), SWEEP_SCHEMA)


def _rewrite_alignments(src: Path, dest: Path) -> None:
    """The committed file is gzipped: compared (and damaged) as its JSON text."""
    text = gzip.decompress(src.read_bytes()) if src.suffix == ".gz" else src.read_bytes()
    plain = dest.parent / "alignments.in.json"
    plain.write_bytes(text)
    write_alignments(dest, *read_alignments(plain))
    dest.write_bytes(
        gzip.compress(dest.read_bytes(), compresslevel=9, mtime=0) if src.suffix == ".gz" else dest.read_bytes()
    )


#: File name -> re-write (read ``src`` with the checked reader, write the record to ``dest``).
REWRITE: dict[str, Callable[[Path, Path], object]] = {
    "ate.json": lambda src, dest: write_ate(dest, *read_ate(src)),
    "map_stats.json": lambda src, dest: write_map_stats(dest, *read_map_stats(src)),
    "timings.json": lambda src, dest: write_timings(dest, read_timings(src)),
    "posegraph.json": lambda src, dest: write_record(dest, read_record(src, dict[str, GraphInfo])),
    "sweep.json": _rewrite_sweep,
    "leaderboard.json": lambda src, dest: write_leaderboard_json(dest, read_leaderboard(src)),
    "manifest.json": lambda src, dest: write_record(
        dest, read_record(src, ManifestRecord, MANIFEST_SCHEMA), MANIFEST_SCHEMA
    ),
    "alignments.json.gz": _rewrite_alignments,
    "benchmark.json": lambda src, dest: write_record(
        dest, read_record(src, BenchmarkRecord, BENCHMARK_SCHEMA), BENCHMARK_SCHEMA
    ),
    "metrics.json": lambda src, dest: write_metrics_json(dest, read_metrics_json(src)),
    "attribution.json": lambda src, dest: write_record(
        dest, read_record(src, AttributionPlan, ATTRIBUTION_SCHEMA), ATTRIBUTION_SCHEMA
    ),
    "fit_state.json": lambda src, dest: write_record(dest, read_record(src, FitStateRecord)),
    "paper_predictions.json": lambda src, dest: write_record(dest, read_predictions(src)),
    "plan.json": lambda src, dest: write_record(dest, read_record(src, PlanRecord)),
    "cell.json": lambda src, dest: write_record(dest, read_record(src, CellStatus)),
    "runtimes.json": lambda src, dest: write_record(dest, read_runtimes(src)),
    "summary.json": lambda src, dest: write_record(dest, read_reference(src)),
    "frontend.json": lambda src, dest: write_record(dest, read_record(src, FrontEndGrades)),
}

FILES = [p for p in committed_files("*.json*") if p.name in REWRITE]
#: Kinds that live inside other committed files (the front-end grades: ``metrics.json``'s ``frontend``).
NESTED = {"frontend.json"}
#: The typed files every run folder holds at its top level.
TYPED_RUN_FILES = ("metrics.json", "ate.json", "map_stats.json", "timings.json", "posegraph.json", "manifest.json")


def test_every_typed_kind_has_committed_files() -> None:
    kinds = {p.name for p in FILES}
    assert kinds == set(REWRITE) - NESTED
    assert sum(p.name == "ate.json" for p in FILES) >= 20


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(RESULTS)))
def test_a_committed_file_reads_and_writes_back_byte_identical(path: Path, tmp_path: Path) -> None:
    out = tmp_path / path.name
    REWRITE[path.name](path, out)
    assert out.read_bytes() == path.read_bytes()


def test_a_fresh_run_writes_its_files_as_the_records_writers_do(smoke_run, tmp_path: Path) -> None:
    """A run's typed files re-read and written back give their bytes: one format, run or committed.

    So a run folder collected into the committed results (``roman-sim reproduce``) changes no
    byte, and a user's own run reads like a committed one.
    """
    run_dir = smoke_run.run_dir
    # alignments.json is committed gzipped; its writer is the same
    names = [*TYPED_RUN_FILES, "alignments.json", "maps/frontend.json"]
    assert (run_dir / "maps" / "frontend.json").is_file()  # the smoke run grades its front end
    for name in names:
        rewrite = REWRITE.get(Path(name).name) or REWRITE[name + ".gz"]
        out = tmp_path / Path(name).name
        rewrite(run_dir / name, out)
        assert out.read_bytes() == (run_dir / name).read_bytes(), name


METRICS = [p for p in FILES if p.name == "metrics.json"]


@pytest.mark.parametrize("path", METRICS, ids=lambda p: str(p.relative_to(RESULTS)))
def test_committed_front_end_grades_read_and_write_back_as_their_own_file(path: Path, tmp_path: Path) -> None:
    """The ``frontend`` section of a committed ``metrics.json``, as ``maps/frontend.json`` holds it:
    the grades record (counts read, rates recomputed) writes the same bytes."""
    section = json.loads(path.read_text(encoding="utf-8")).get("frontend")
    if section is None:
        pytest.skip("this run graded no front end")
    src = tmp_path / "in.json"
    src.write_text(json.dumps(section, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    REWRITE["frontend.json"](src, tmp_path / "frontend.json")
    assert (tmp_path / "frontend.json").read_bytes() == src.read_bytes()


@pytest.mark.parametrize(
    ("name", "edit", "message"),
    [
        ("ate.json", lambda d: d["variants"][1].update(fit="sideways"), "field variants[1].fit: expected one of"),
        ("map_stats.json", lambda d: d.update(submaps="many"), "field submaps: expected an integer"),
        ("timings.json", lambda d: d["stages"]["maps"].pop("reused"), "field stages.maps.reused: missing"),
        ("posegraph.json", lambda d: d["roman"].update(inliers=None), "field roman.inliers: expected an integer"),
        ("metrics.json", lambda d: d["config"].update(k_max="many"), "field config.k_max: "),
        ("metrics.json", lambda d: d["pairs"]["inter"].pop("n_relevant"), "field pairs.inter.n_relevant: missing"),
        (
            "metrics.json",
            lambda d: d["methods"]["roman"]["inter"]["heading_bins"][1].update(max_hits=2.5),
            "field methods.roman.inter.heading_bins[1].max_hits: expected an integer, got a number (2.5)",
        ),
        (
            "metrics.json",
            lambda d: d["methods"]["roman"]["inter"]["pr_curve"]["recall"].append("x"),
            "field methods.roman.inter.pr_curve.recall[31]: expected a number, got a string",
        ),
        (
            "metrics.json",
            lambda d: d["frontend"]["segmentation"].update(frames=None),
            "field frontend.segmentation.frames: expected an integer, got null",
        ),
        (
            "metrics.json",
            lambda d: d["revisits"]["all"].update(median_overlap="most"),
            "field revisits.all.median_overlap: expected a number, got a string ('most')",
        ),
    ],
)
def test_a_damaged_run_file_names_the_file_and_field(
    name: str, edit: Callable[[dict], object], message: str, tmp_path: Path
) -> None:
    data = json.loads((REFERENCE / "demo" / name).read_text(encoding="utf-8"))
    edit(data)
    bad = tmp_path / name
    bad.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(RecordError) as err:
        REWRITE[name](bad, tmp_path / "out.json")
    assert str(err.value).startswith(f"{bad}: {message}")


def test_a_stage_taken_from_the_shared_cache_has_no_time(tmp_path: Path) -> None:
    """A stage another folder computed is reused without being timed here: only ``reused`` is known."""
    timings = run_timings({"maps": {"reused": True}, "ate": {"seconds": 0.5, "peak_rss_mb": None, "reused": False}})
    assert timings.stages["maps"].seconds is None and timings.stages["ate"].seconds == 0.5
    write_timings(tmp_path / "timings.json", timings)
    assert read_timings(tmp_path / "timings.json") == timings
    written = json.loads((tmp_path / "timings.json").read_text())["stages"]
    assert written["maps"] == {"peak_rss_mb": None, "reused": True}


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["table1"][0].pop("common"), "field table1[0].common: missing"),
        (
            lambda d: d["claims"][0].update(holds="yes"),
            "field claims[0].holds: expected a boolean, got a string ('yes')",
        ),
        (lambda d: d["revisits"][0].update(seen=1), "field revisits[0].seen: unknown (valid: scenario, n_relevant,"),
        (
            lambda d: d["runs"]["same_direction"].update(map={"robots": 2}),
            "field runs.same_direction.map.segments: missing",
        ),
        (
            lambda d: d["operating_points"][0]["recall"]["points"].update(best={}),
            "field operating_points[0].recall.points.best: unknown key (valid: max_recall,",
        ),
        (lambda d: d["claims"][0].pop("id"), "field claims[0].id: missing"),
        (lambda d: d["comparison"][0].pop("cross-robot"), "field comparison[0].cross-robot: missing"),
    ],
)
def test_a_damaged_reference_summary_names_the_file_and_field(
    edit: Callable[[dict], object], message: str, tmp_path: Path
) -> None:
    data = json.loads((REFERENCE / "summary.json").read_text(encoding="utf-8"))
    edit(data)
    bad = tmp_path / "summary.json"
    bad.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(RecordError) as err:
        read_reference(bad)
    assert str(err.value).startswith(f"{bad}: {message}")
