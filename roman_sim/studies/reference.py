"""Reference results: run the paper's experiments, keep their raw data, put them next to the paper.

``reproduce`` runs each scenario (cached in a work folder) and copies into
``out_dir/<scenario>/`` the small results (``metrics.json``, ``ate.json``, ``report.md``,
configuration, manifest, timings, the main plots) and the raw data, gzip-compressed:
``pairs.csv.gz``, ``alignments.json.gz``, ``runtimes.csv.gz`` (per-pair runtimes) and
``trajectories/*.tum.gz``, with the submap packets in ``packets/<robot>.npz``
(``roman_sim.studies.raw_data``). The ambiguity sweep keeps ``sweep.json``,
``sweep_summary.csv`` and each run's pairs table and estimates. The independent scorer
(``roman_sim.studies.independent_scorer``) re-derives the summary's figures and claims from these files. Then it writes
``summary.json`` (every run's compact summary, the comparison with the paper, the claims)
and ``summary.md``. The demo's run is collected too (``out_dir/demo``, outside the summary).
``write_pages`` renders the documentation's generated blocks from the same files
(``roman_sim.studies.pages``): the results page, the README's demo excerpt and its figure.

``rederive`` recomputes ``summary.json`` from the committed raw files alone (metrics from
the pairs tables, ATE from the trajectories, runtimes from the timings, map sizes from the
map statistics), so a test can check that every number and claim follows from them.
"""

from __future__ import annotations

import gzip
import logging
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from roman_sim.core.atomic import write_bytes, write_text
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import read_record, write_record
from roman_sim.evaluation.records import RunTimings, read_map_stats, read_timings, write_timings
from roman_sim.evaluation.results import read_metrics_json, write_metrics_json
from roman_sim.evaluation.run_summary import RunSummary
from roman_sim.pipeline.manifest import MANIFEST_JSON, read_manifest
from roman_sim.pipeline.sweep_aggregate import read_sweep_json
from roman_sim.studies import pages
from roman_sim.studies.claims import (
    PAPER,
    Runs,
    SweepRow,
    claims,
    claims_markdown,
    comparison,
    sweep_markdown,
    table_markdown,
)
from roman_sim.studies.raw_data import write_packets, write_runtimes
from roman_sim.studies.reference_tables import (
    ReferenceRecord,
    frontends,
    frontends_markdown,
    operating_points,
    operating_points_markdown,
    revisits,
    revisits_markdown,
    table1,
    table1_markdown,
)

if TYPE_CHECKING:
    from roman_sim.evaluation.sweepstats import SweepCell
    from roman_sim.runner.executor_base import ExecutorConfig

log = logging.getLogger(__name__)

PAPER_SCENARIOS = [
    "same_direction",
    "same_direction_replay",  # the same loop as a replay: what the revisit's offsets change
    "partial_opposite",
    "opposite_direction",
    "heading_sweep",
    "multi_robot_tunnel",
    "multi_robot_hybrid",
    "multi_robot_outdoor",
    "opposite_direction_pixels",  # the opposite-direction scenario with the image front end
]
#: Paper-sized multi-robot scenarios (6-8 robots, about 1 km each; tens of minutes each), run on request:
#: ``roman-sim reproduce --scenario kimera_tunnel --scenario kimera_hybrid --scenario kimera_outdoor``.
PAPER_SCALE_SCENARIOS = ["kimera_tunnel", "kimera_hybrid", "kimera_outdoor"]
SMALL_FILES = ("ate.json", "report.md", "config.yaml", "posegraph.json", "map_stats.json", "manifest.json")
#: Raw data kept compressed (the pairs table, each method's estimates).
RAW_FILES = ("pairs.csv", "alignments.json")
#: Plots kept (with the pose graph method's example alignments); the others are redrawn by any run.
KEPT_PLOTS = (
    "recall_heading.png",
    "precision_recall.png",
    "precision_recall_heading.png",
    "association_heading.png",
    "recall_ambiguity.png",
    "trajectories.png",
    "segments_on_image.png",
)
#: The sweep run with the paper's scenarios: recall against the ambiguity knob.
AMBIGUITY_SWEEP = "sweeps/ambiguity_sweep.yaml"
AMBIGUITY_KEY = "world.overrides.ambiguity"
#: The demo scenario, collected next to the reference runs for the README's excerpt (not in the summary).
DEMO = "demo"
#: Pages with generated blocks, relative to the repository root.
RESULTS_PAGE, FIGURE_PNG, README = Path("docs/results.md"), Path("docs/recall_heading.png"), Path("README.md")


def _gzip_copy(src: Path, dest: Path) -> None:
    write_bytes(dest, gzip.compress(src.read_bytes(), compresslevel=9, mtime=0))


def _timing_figures(path: Path) -> RunTimings:
    """``timings.json`` without the per-pair runtime lists (the statistics are kept)."""
    timings = read_timings(path)
    for stage in timings.stages.values():
        for method in (stage.alignment or {}).values():
            method.per_pair_s = None
    return timings


def _report_without(text: str, missing: list[str]) -> str:
    """``report.md`` without the image lines of plots that were not kept, saying which."""
    lines = [ln for ln in text.splitlines() if not any(f"](plots/{m})" in ln for m in missing)]
    if missing:
        lines += ["", "Plots not kept in the reference results (any run draws them): " + ", ".join(missing) + "."]
    return "\n".join(lines) + "\n"


def collect(run_dir: Path, dest: Path, trajectories: bool = True, plots: bool = True, packets: bool = True) -> None:
    """Copy a run's small results and its raw data (gzip) into ``dest``.

    ``manifest.json`` is written without its files' SHA-256 (they are those of the run
    folder, whose files are compressed or left out here); ``metrics.json`` is checked by its
    reader and written again (the same bytes: a run writes it in the committed format);
    ``timings.json`` without its per-pair runtime lists (medians, means and 90th percentiles
    per method stay); the plots kept are ``KEPT_PLOTS`` and the pose-graph method's example
    alignments, and ``report.md`` names the others instead of linking them.
    """
    dest.mkdir(parents=True, exist_ok=True)
    for name in SMALL_FILES:
        if (run_dir / name).is_file() and name not in ("report.md", MANIFEST_JSON):
            shutil.copyfile(run_dir / name, dest / name)
    if (run_dir / MANIFEST_JSON).is_file():  # what ran; the hashes are of the run folder's files, not these
        read_manifest(run_dir).without_hashes().save(dest)
    write_metrics_json(dest / "metrics.json", read_metrics_json(run_dir / "metrics.json"))
    if (run_dir / "timings.json").is_file():
        write_timings(dest / "timings.json", _timing_figures(run_dir / "timings.json"))
    for name in RAW_FILES:
        if (run_dir / name).is_file():
            _gzip_copy(run_dir / name, dest / f"{name}.gz")
    if packets:
        write_packets(run_dir, dest)
    runtimes = write_runtimes(run_dir, dest)
    if runtimes is not None:
        _gzip_copy(runtimes, dest / f"{runtimes.name}.gz")
        runtimes.unlink()
    if trajectories and (run_dir / "trajectories").is_dir():
        for p in sorted((run_dir / "trajectories").glob("*.tum")):
            _gzip_copy(p, dest / "trajectories" / f"{p.name}.gz")
    drawn = sorted(p.name for p in (run_dir / "plots").glob("*.png")) if (run_dir / "plots").is_dir() else []
    method = _config_value(run_dir, "posegraph_method")
    keep = [n for n in drawn if plots and (n in KEPT_PLOTS or n == f"alignment_{method}.png")]
    for name in keep:
        (dest / "plots").mkdir(parents=True, exist_ok=True)
        shutil.copyfile(run_dir / "plots" / name, dest / "plots" / name)
    if (run_dir / "report.md").is_file():
        text = (run_dir / "report.md").read_text(encoding="utf-8")
        write_text(dest / "report.md", _report_without(text, [n for n in drawn if n not in keep]))


def _report_notes(text: str) -> list[str]:
    """The bullets of a report's ``## Notes`` section."""
    lines = text.splitlines()
    if "## Notes" not in lines:
        return []
    out = []
    for ln in lines[lines.index("## Notes") + 1 :]:
        if ln.startswith("## "):
            break
        if ln.startswith("- "):
            out.append(ln[2:])
    return out


def rewrite_report(folder: str | Path) -> Path:
    """Write a collected run's ``report.md`` again in the current layout, from its committed files alone.

    The figures come from ``metrics.json``, ``ate.json`` and ``map_stats.json``, the notes from
    the report's own notes section, the plots from ``plots/`` and the report's list of plots not
    kept; no other file is touched.

    Raises:
        StorageError: the folder has no ``report.md`` or ``metrics.json``.
    """
    from roman_sim.core.config import read_yaml
    from roman_sim.evaluation.atetable import read_ate
    from roman_sim.report.markdown import report_markdown

    d = Path(folder)
    if not (d / "report.md").is_file() or not (d / "metrics.json").is_file():
        raise StorageError(f"{d}: not a collected run folder (report.md and metrics.json are needed)")
    old = (d / "report.md").read_text(encoding="utf-8")
    marker = "Plots not kept in the reference results (any run draws them): "
    missing = [ln[len(marker) : -1].split(", ") for ln in old.splitlines() if ln.startswith(marker)]
    not_kept = missing[0] if missing else []
    kept = sorted(p.name for p in (d / "plots").glob("*.png")) if (d / "plots").is_dir() else []
    config = read_yaml(d / "config.yaml")
    ate = read_ate(d / "ate.json")[0] if (d / "ate.json").is_file() else None
    stats = read_map_stats(d / "map_stats.json")[0] if (d / "map_stats.json").is_file() else None
    plots = [f"plots/{n}" for n in sorted(kept + not_kept)]
    name = str(config["name"]) if isinstance(config, dict) else d.name
    text = report_markdown(name, read_metrics_json(d / "metrics.json"), ate, stats, _report_notes(old), plots)
    write_text(d / "report.md", _report_without(text, not_kept))
    return d / "report.md"


def _config_value(run_dir: Path, key: str) -> JSON:
    from roman_sim.core.config import read_yaml

    data = read_yaml(run_dir / "config.yaml") if (run_dir / "config.yaml").is_file() else {}
    return data.get(key) if isinstance(data, dict) else None


def reproduce(
    out_dir: str | Path,
    scenarios: list[str] | None = None,
    work_dir: str | Path = "results/work",
    on_start: Callable[[str], None] | None = None,
    from_stage: str | None = None,
    root: str | Path | None = None,
    executor: ExecutorConfig | None = None,
) -> Path:
    """Run ``scenarios`` (default: the paper's, the demo and the ambiguity sweep), collect, write the summary.

    ``root``: a repository whose generated documentation blocks are rewritten from the new
    summary (``write_pages``). A run of some scenarios only updates the summary already in
    ``out_dir`` (``merge_committed``): the other scenarios and the sweep stay as committed.
    ``DEMO`` among ``scenarios`` re-collects the demo only. Installed versions that differ
    from the lock (``constraints.txt`` under ``root``, else the working folder) are named in
    one warning first (``roman_sim.studies.lockfile``). ``executor`` (an
    ``ExecutorConfig``) spreads each run's robots and pairs over workers (the results do not
    depend on it).
    """
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.studies.lockfile import warn_unlocked

    warn_unlocked(root if root is not None else ".")  # another environment: which versions differ from the lock
    out, work = Path(out_dir), Path(work_dir)
    runs: dict[str, RunSummary] = {}
    for name in scenarios or [*PAPER_SCENARIOS, DEMO]:
        if on_start:
            on_start(name)
        res = Experiment(load_scenario(name), work / name, from_stage=from_stage, executor=executor).run()
        if (out / name).is_dir():
            shutil.rmtree(out / name)
        collect(res.run_dir, out / name, plots=name != DEMO)
        if name != DEMO:
            runs[name] = res.summary()
    sweep: list[SweepRow] = []
    if scenarios is None:
        if on_start:
            on_start("ambiguity_sweep")
        sweep = ambiguity_sweep(out / "ambiguity_sweep", work / "ambiguity_sweep", from_stage)
        runs, _ = merge_committed(out, runs)  # the paper-scale runs (run on request) keep their results
    else:
        runs, sweep = merge_committed(out, runs)
    summary = build_reference(runs, sweep)
    write_record(out / "summary.json", summary)
    write_text(out / "summary.md", reference_markdown(summary))
    if root is not None:
        write_pages(Path(root), out, summary)
    return out / "summary.md"


def write_pages(root: Path, ref_dir: Path, summary: ReferenceRecord) -> None:
    """Rewrite the generated documentation blocks under ``root`` from the reference results.

    The results page's block from ``summary``, the README's figure, and the README's demo
    excerpt from the demo's committed run (when ``ref_dir / DEMO`` holds one). A page
    without its markers is left as it is, with a warning.
    """
    targets = [(root / RESULTS_PAGE, pages.RESULTS_MARKERS, pages.results_block(summary))]
    if (ref_dir / DEMO / "pairs.csv.gz").is_file():
        targets.append((root / README, pages.DEMO_MARKERS, pages.demo_block(demo_summary(ref_dir))))
    for path, markers, block in targets:
        if not path.is_file() or not pages.update_block(path, markers, block):
            log.warning("%s has no %s / %s markers: its generated block was not updated", path, *markers)
    if (root / FIGURE_PNG).parent.is_dir() and pages.figure_data(summary).methods:
        pages.write_figure(summary, root / FIGURE_PNG)


def demo_summary(ref_dir: str | Path) -> RunSummary:
    """The committed demo run's compact summary, recomputed from its raw files."""
    return _run_summary(Path(ref_dir) / DEMO)


def _knob(v: object) -> float:
    if not isinstance(v, (int, float)):
        raise StorageError(f"{AMBIGUITY_KEY}: expected a number, got {v!r}")
    return float(v)


def _sweep_rows(rows: list[SweepCell]) -> list[SweepRow]:
    """Cross-robot overall rows of a sweep's aggregate over seeds, per ambiguity knob and method."""
    return [
        SweepRow(
            ambiguity=_knob(r.params[AMBIGUITY_KEY]),
            method=r.method,
            recall=r.pooled_recall,
            hits=r.hits,
            relevant=r.relevant,
            ci=None if r.wilson_low is None or r.wilson_high is None else (r.wilson_low, r.wilson_high),
            n_seeds=r.n_seeds,
        )
        for r in rows
        if r.kind == "inter" and r.bin == "all"
    ]


def ambiguity_sweep(dest: Path, work: Path, from_stage: str | None = None) -> list[SweepRow]:
    """Run (or resume) the ambiguity sweep; keep its aggregate over seeds and each run's raw pairs table."""
    from roman_sim.pipeline.scenario import SCENARIO_DIR
    from roman_sim.pipeline.sweep import load_sweep, run_sweep
    from roman_sim.pipeline.sweep_aggregate import AGGREGATE_CSV, SWEEP_JSON, aggregate_sweep, read_sweep_json

    cfg, scenario = load_sweep(SCENARIO_DIR / AMBIGUITY_SWEEP)
    cfg.executor.kind = "serial"
    run_sweep(cfg, scenario, work, from_stage=from_stage)
    if dest.is_dir():
        shutil.rmtree(dest)
    dest.mkdir(parents=True)
    for name in (SWEEP_JSON, AGGREGATE_CSV, "sweep.csv", "plots/sweep_summary.png"):
        if (work / name).is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(work / name, dest / name)
    for r in read_sweep_json(work).runs:
        collect(work / r.run_id, dest / r.run_id, trajectories=False, plots=False, packets=False)
    return _sweep_rows(aggregate_sweep(work)[1])


def merge_committed(out: Path, runs: dict[str, RunSummary]) -> tuple[dict[str, RunSummary], list[SweepRow]]:
    """The runs of a subset run together with the results already in ``out``, and the sweep rows.

    Every scenario of ``out/summary.json`` that was not re-run keeps its committed results; its
    summary (and the ambiguity sweep's rows) are recomputed from its raw files, as ``rederive``
    does, so the merged summary follows from the raw data with the current code. A listed
    scenario whose folder is gone is dropped with a warning. Order: the committed scenarios,
    then the new ones.
    """
    if not (out / "summary.json").is_file():
        return runs, []
    merged: dict[str, RunSummary] = {}
    for name in read_reference(out / "summary.json").runs:
        if name in runs:
            merged[name] = runs[name]
        elif (out / name / "pairs.csv.gz").is_file():
            merged[name] = _run_summary(out / name)
        else:
            log.warning("%s: no committed results in %s; dropped from the summary", name, out / name)
    merged.update({k: v for k, v in runs.items() if k not in merged})
    return merged, _committed_sweep(out)


def _committed_sweep(d: Path) -> list[SweepRow]:
    """The ambiguity sweep's rows recomputed from its committed raw files ([] without a sweep)."""
    from roman_sim.evaluation.sweepstats import aggregate, seed_rows

    if not (d / "ambiguity_sweep" / "sweep.json").is_file():
        return []
    spec = read_sweep_json(d / "ambiguity_sweep")
    rows = []
    for r in spec.runs:
        s = _run_summary(d / "ambiguity_sweep" / r.run_id)
        rows += seed_rows({k: r.params[k] for k in spec.grid}, r.seed, s)
    return _sweep_rows(aggregate(rows, spec.grid))


def read_reference(path: str | Path) -> ReferenceRecord:
    """The ``summary.json`` at ``path``, every field checked (RecordError names the file and the field)."""
    return read_record(path, ReferenceRecord)


def build_reference(runs: Runs, sweep: list[SweepRow]) -> ReferenceRecord:
    """``summary.json``: the runs, the comparison with the paper, Table I, the two front ends, the
    operating points, the claims, the sweep rows."""
    tables = (table1(runs), frontends(runs), operating_points(runs), revisits(runs))
    return ReferenceRecord(dict(runs), comparison(runs), *tables, claims(runs, sweep), sweep, PAPER)


def _tables_markdown(summary: ReferenceRecord) -> str:
    return (
        table1_markdown(summary.table1)
        + frontends_markdown(summary.frontends)
        + operating_points_markdown(summary.operating_points)
        + revisits_markdown(summary.revisits)
    )


def reference_markdown(summary: ReferenceRecord) -> str:
    """``summary.md``: the comparison table, the claims and the ambiguity sweep."""
    return (
        "# Reference results next to the paper\n\n"
        "Recall cells: cross-robot (or same-robot) max recall over the association threshold k, "
        "(hits/relevant) [95 % Wilson interval], then P, the precision at the highest k that keeps "
        "those hits, and that k; 'n<5' marks fewer than 5 relevant pairs. Recall at precision >= 0.9, "
        "at precision 1 and at the acceptance threshold: the operating points table. "
        "Every pair of submaps is aligned and scored.\n\n"
        + table_markdown(summary.comparison)
        + _tables_markdown(summary)
        + "\n"
        + claims_markdown(summary.claims)
        + sweep_markdown(summary.ambiguity_sweep)
    )


def _run_summary(d: Path) -> RunSummary:
    """A run's compact summary recomputed from its committed raw files."""
    from roman_sim.evaluation.run_summary import summarize_run
    from roman_sim.report.recompute import recompute_ate, recompute_metrics

    metrics, _ = recompute_metrics(d, "pairs.csv.gz", as_stored=False)
    ate = recompute_ate(d, ".gz") if (d / "ate.json").is_file() and (d / "trajectories").is_dir() else None
    stats, _ = read_map_stats(d / "map_stats.json")
    timings = read_timings(d / "timings.json")
    runtimes = {m: timings.median_s(m) for m in metrics.methods}
    return summarize_run(metrics, ate, stats, runtimes)


def rederive(ref_dir: str | Path) -> ReferenceRecord:
    """``summary.json`` recomputed from the raw files under ``ref_dir`` (scenarios as committed)."""
    d = Path(ref_dir)
    committed = read_reference(d / "summary.json")
    runs = {name: _run_summary(d / name) for name in committed.runs}
    return build_reference(runs, _committed_sweep(d))
