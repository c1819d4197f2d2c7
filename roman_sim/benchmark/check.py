"""Checking a finished benchmark's board on worlds it never saw (``roman-sim benchmark check FOLDER --seeds A:B``).

A board states, per level and method, the threshold a new world runs at (``Deployable.deployed``:
chosen on every world of the level), the interval one new world's precision falls in
(``Deployable.spread``: a beta-binomial fit of the held-out worlds' precisions) and, per heading
bin, paired verdicts ("a ahead", "b ahead"). The check runs fresh worlds, every level of the suite
at seeds A..B-1 (seeds the board never used), with the same suite definition, methods and
overrides, into ``FOLDER/check-<A>-<B>/`` (a benchmark job of its own: resumable, its cells kept
as the board's are), scores each fresh world at the committed thresholds (not chosen again) and
reports, verdict by verdict, whether they held:

- the precision target: per level and method, the fresh worlds' pooled precision at the deployed
  threshold (held when within ``transfer.PRECISION_SLACK`` of the target, as the board's own flag),
  and per fresh world whether its hits lie in the interval the board's fit gives a world that
  accepts as many pairs (``WorldSpread.hits_interval``);
- every paired verdict the board states: whether the fresh worlds' paired difference of recall at
  the deployed thresholds has the same sign, and whether the same exact test
  (``paired_worlds.paired_difference``) finds it there too.

Files: ``check.json`` (``BoardCheck``) and ``check.md`` in the check folder. Bad input (a folder
that is not a finished benchmark, a board without deployed thresholds, a suite definition that
changed since the board was run, seeds the board used, a malformed ``--seeds``) is refused in one
line before anything is written.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.benchmark.board import LEADERBOARD_JSON, load_levels, read_record
from roman_sim.benchmark.board_records import Deployable, Leaderboard, PairVerdict, read_leaderboard
from roman_sim.benchmark.cells import BENCHMARK_JSON, BenchmarkRecord
from roman_sim.benchmark.check_markdown import check_markdown
from roman_sim.benchmark.check_records import (
    CHECK_SCHEMA,
    BoardCheck,
    FreshWorld,
    LevelCheck,
    PrecisionCheck,
    VerdictCheck,
)
from roman_sim.benchmark.deployable import WorldCounts, bin_masks, outcomes, world_counts
from roman_sim.benchmark.run import BenchmarkJob, BenchmarkOutcome, ProgressFn
from roman_sim.benchmark.suites import SUITES, BenchmarkSuite
from roman_sim.benchmark.transfer import PRECISION_SLACK, positives, transfers
from roman_sim.benchmark.world_spread import WorldSpread
from roman_sim.core.atomic import write_text
from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, EvaluationError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import RecordError, write_record
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.paired_worlds import paired_difference
from roman_sim.evaluation.score_curves import check_score
from roman_sim.runner.executors import ExecutorConfig

log = logging.getLogger(__name__)

CHECK_JSON = "check.json"
CHECK_MD = "check.md"


# -- input ----------------------------------------------------------------------------------
def parse_seeds(text: str) -> tuple[int, int]:
    """``A:B`` -> ``(A, B)``: fresh seeds A..B-1, at least two (the paired test needs two worlds).

    Raises:
        ConfigError: anything else, in one line naming ``--seeds``.
    """
    lo_hi = text.split(":")
    try:
        lo, hi = (int(x) for x in lo_hi)
    except ValueError:
        raise ConfigError(f"--seeds: expected A:B (fresh seeds A to B-1, e.g. 100:104), got {text!r}") from None
    if lo < 0 or hi - lo < 2:
        raise ConfigError(f"--seeds: A:B takes 0 <= A and at least two seeds (A + 2 <= B), got {text!r}")
    return lo, hi


#: Suite fields that describe a suite without deciding its cells (not compared by ``current_suite``).
PAPER_ONLY = ("description", "power")


def check_dir(folder: str | Path, seeds: tuple[int, int]) -> Path:
    """Where a check of ``folder`` on ``seeds`` runs: ``FOLDER/check-<A>-<B>``."""
    return Path(folder) / f"check-{seeds[0]}-{seeds[1]}"


def first_difference(old: JSON, new: JSON, where: str = "") -> tuple[str, JSON, JSON] | None:
    """The first field (dotted path, keys in sorted order) where two JSON values differ, and both values."""
    if isinstance(old, dict) and isinstance(new, dict):
        for key in sorted(set(old) | set(new)):
            path = f"{where}.{key}" if where else str(key)
            if key not in old or key not in new:
                return path, old.get(key, "absent"), new.get(key, "absent")
            got = first_difference(old[key], new[key], path)
            if got is not None:
                return got
        return None
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        for i, (a, b) in enumerate(zip(old, new, strict=True)):
            got = first_difference(a, b, f"{where}[{i}]")
            if got is not None:
                return got
        return None
    return None if old == new else (where or "(the whole definition)", old, new)


def current_suite(folder: Path, record: BenchmarkRecord) -> BenchmarkSuite:
    """The suite the board was run with, as it is defined now: the built-in suite of its name (refused when its
    definition changed since, in a field that decides the cells: the fields of ``PAPER_ONLY``, its description
    and its power plan, say what the suite is for and are not compared), or the recorded definition of a suite
    file.

    Raises:
        ConfigError: the built-in suite's definition differs (naming the first differing field).
    """
    if record.suite not in SUITES:
        return validate_model(BenchmarkSuite, record.suite_spec, source=f"{folder / BENCHMARK_JSON}: suite_spec")
    suite = SUITES.get(record.suite)
    try:  # a field added to suites since keeps its default in the recorded definition
        spec = validate_model(BenchmarkSuite, record.suite_spec, source="suite_spec").model_dump(mode="json")
    except ConfigError:
        spec = dict(record.suite_spec)
    recorded = {k: v for k, v in spec.items() if k not in PAPER_ONLY}
    now = {k: v for k, v in suite.model_dump(mode="json").items() if k not in PAPER_ONLY}
    diff = first_difference(recorded, now)
    if diff is not None:
        path, old, new = diff
        raise ConfigError(
            f"{folder}: from another suite version: the recorded {record.suite!r} suite differs from the current "
            f"one in {path} (recorded {old!r}, now {new!r}); run the suite again into a new folder to check it"
        )
    return suite


def _board(folder: Path, record: BenchmarkRecord) -> Leaderboard:
    """The folder's leaderboard, with deployed thresholds and one-new-world intervals for some level."""
    path = folder / LEADERBOARD_JSON
    rerender = f"re-render it with `roman-sim benchmark {record.suite} --report-only --out {folder}`"
    if not path.is_file():
        raise ConfigError(f"{folder}: not a finished benchmark (no {LEADERBOARD_JSON}; {rerender})")
    try:
        board = read_leaderboard(path)
    except RecordError as err:
        raise ConfigError(f"{err} (an older leaderboard schema: {rerender})") from None
    for e in board.levels:
        d = e.deployable
        if d is not None and d.note is None and (d.deployed is None or d.spread is None):
            raise ConfigError(
                f"{path}: level {e.name!r} states no deployed thresholds or one-new-world intervals (an older "
                f"leaderboard schema: {rerender})"
            )
    if not any(_checkable(e.deployable) for e in board.levels):
        raise ConfigError(f"{path}: no level states deployed thresholds (each needs two worlds or more)")
    return board


def _checkable(d: Deployable | None) -> bool:
    return d is not None and d.note is None and d.deployed is not None


@dataclass(frozen=True)
class CheckInput:
    """A check's input, checked: the board's record and leaderboard, the suite to run on the fresh seeds (the
    current definition, its seeds replaced by them) and the seeds' range ``(A, B)``."""

    record: BenchmarkRecord
    board: Leaderboard
    suite: BenchmarkSuite
    seeds: tuple[int, int]


def prepare(folder: str | Path, seeds_text: str) -> CheckInput:
    """The input of a check of ``folder`` on seeds ``A:B``, checked before anything is written.

    Raises:
        ConfigError: malformed seeds, a folder that is not a finished benchmark, a board without deployed
            thresholds, another suite version, or seeds the board used (one line each).
    """
    seeds = parse_seeds(seeds_text)
    folder = Path(folder)
    if not (folder / BENCHMARK_JSON).is_file():
        raise ConfigError(
            f"{folder}: not a finished benchmark (no {BENCHMARK_JSON}; run `roman-sim benchmark SUITE --out {folder}`)"
        )
    record = read_record(folder)
    pending = [c.id for c in record.cells if c.status == "pending"]
    if pending or not record.cells:
        raise ConfigError(
            f"{folder}: not a finished benchmark ({len(pending)} cells pending, first {pending[0]}; run the "
            "benchmark again to finish it)"
            if pending
            else f"{folder}: not a finished benchmark (no cell)"
        )
    suite = current_suite(folder, record)
    board = _board(folder, record)
    used = sorted({c.seed for c in record.cells})
    overlap = sorted(set(range(*seeds)) & set(used))
    if overlap:
        start = used[-1] + 1
        raise ConfigError(
            f"--seeds {seeds[0]}:{seeds[1]}: seed {overlap[0]} is one of the board's own ({used[0]}-{used[-1]}); "
            f"choose seeds it never used, e.g. {start}:{start + seeds[1] - seeds[0]}"
        )
    data = suite.model_dump(mode="json")
    # a check runs exactly the fresh seeds: no seed added, no power plan to meet
    data.update(seeds=list(range(*seeds)), min_worlds=None, min_relevant_per_bin=None, power=None)
    fresh = validate_model(BenchmarkSuite, data, source=f"suite {suite.name} on seeds {seeds[0]}:{seeds[1]}")
    return CheckInput(record, board, fresh, seeds)


# -- scoring --------------------------------------------------------------------------------
def _fresh_world(world: str, hits: int, accepted: int, fit: WorldSpread | None, level: float) -> FreshWorld:
    if not accepted:
        return FreshWorld(world, hits, 0, None, None, None)
    if fit is None:
        return FreshWorld(world, hits, accepted, hits / accepted, None, None)
    lo, hi = fit.hits_interval(accepted, level)
    return FreshWorld(world, hits, accepted, hits / accepted, [lo, hi], lo <= hits <= hi)


def _precision(d: Deployable, method: str, counts: WorldCounts, worlds: list[str]) -> PrecisionCheck:
    """``method``'s fresh precision at its deployed threshold (``counts``: its ``WorldCounts`` over all headings)."""
    spread = (d.spread or {}).get(method)
    fit = None if spread is None else WorldSpread(spread.a, spread.b, spread.worlds)
    level = 0.95 if spread is None else spread.level
    per = [
        _fresh_world(w, int(h), int(h + f), fit, level)
        for w, h, f in zip(worlds, counts.hits, counts.false_positives, strict=True)
    ]
    tp, fp = int(counts.hits.sum()), int(counts.false_positives.sum())
    precision = tp / (tp + fp) if tp + fp else None
    return PrecisionCheck(
        method,
        (d.deployed or {}).get(method),
        tp,
        fp,
        precision,
        transfers(precision, d.target_precision),
        None if spread is None else list(spread.interval),
        per,
    )


def _verdict(heading: str, v: PairVerdict, a: WorldCounts, b: WorldCounts) -> VerdictCheck:
    """A stated verdict against the fresh worlds' counts of its two methods (``WorldCounts`` in the bin)."""
    n = int(a.relevant.sum())
    diff = (float(a.hits.sum()) - float(b.hits.sum())) / n if n else None
    sign = 1.0 if v.verdict == "a ahead" else -1.0
    held = None if diff is None else sign * diff > 0
    fresh, p, significant = None, None, None
    if len(a.hits) >= 2:
        d = paired_difference(a.hits, b.hits, a.relevant)
        fresh, p, significant = d.verdict, d.p_value, d.verdict == v.verdict
    return VerdictCheck(
        heading, v.a, v.b, v.verdict, v.diff, int(a.hits.sum()), int(b.hits.sum()), n, diff, held, fresh, p, significant
    )


def check_level(
    d: Deployable,
    name: str,
    scores: list[PairScore],
    edges: list[float],
    methods: list[str],
    score: str = DEFAULT_SCORE,
) -> LevelCheck:
    """One level's fresh worlds (``scores``, pooled with cell-prefixed pair names) against its deployable point,
    the methods in the order of ``methods``; each pair accepted when its score ``score`` (the board's) reaches
    the deployed threshold."""
    worlds = sorted({s.truth.a.split(":", 1)[0] for s in scores})
    if not worlds:
        return LevelCheck(name, [], note="no fresh world of the level finished")
    per_bin: dict[str, dict[str, WorldCounts]] = {}
    precision = []
    deployed = d.deployed or {}
    for m in [x for x in methods if x in deployed]:
        o, heading = outcomes(scores, m, score)
        if len(o.score) == 0:
            continue
        pos = positives(o, deployed[m])
        for label, mask in bin_masks(heading, edges):
            per_bin.setdefault(label, {})[m] = world_counts(o, pos, mask, worlds)
        precision.append(_precision(d, m, per_bin["all"][m], worlds))
    verdicts = [
        _verdict(c.heading, v, counts[v.a], counts[v.b])
        for c in d.cells()
        if (counts := per_bin.get(c.heading)) is not None
        for v in c.verdicts
        if v.winner() is not None and v.a in counts and v.b in counts
    ]
    return LevelCheck(name, worlds, precision, verdicts)


def score_check(board: Leaderboard, out: str | Path, seeds: tuple[int, int]) -> BoardCheck:
    """The check of ``board`` from the fresh cells kept in ``out`` (a finished check folder)."""
    out = Path(out)
    record = read_record(out)
    levels, missing = load_levels(out, record)
    edges = [float(e) for e in board.heading_edges_deg]
    rows = []
    for e in board.levels:
        d = e.deployable
        if d is None or not _checkable(d):
            rows.append(LevelCheck(e.name, [], note=d.note if d is not None and d.note else "no deployed thresholds"))
            continue
        assert d is not None
        lv = levels.get(e.name)
        if lv is not None:
            try:
                check_score(lv.scores, board.score)
            except EvaluationError as err:
                raise ConfigError(f"check: the fresh worlds cannot be scored as the board is: {err}") from None
        rows.append(check_level(d, e.name, [] if lv is None else lv.scores, edges, board.methods, board.score))
    target = board.target_precision if board.target_precision is not None else 0.9
    return BoardCheck(board.suite, [seeds[0], seeds[1]], target, PRECISION_SLACK, missing, rows)


def write_check(out: str | Path, result: BoardCheck) -> list[Path]:
    """Write ``check.json`` and ``check.md`` into ``out``; the paths written."""
    out = Path(out)
    write_record(out / CHECK_JSON, result, CHECK_SCHEMA)
    write_text(out / CHECK_MD, check_markdown(result))
    return [out / CHECK_JSON, out / CHECK_MD]


def run_check(
    folder: str | Path,
    seeds_text: str,
    executor: ExecutorConfig | None = None,
    progress: ProgressFn | None = None,
) -> tuple[BoardCheck, BenchmarkOutcome]:
    """Check ``folder``'s board on fresh seeds (``A:B``): run the fresh cells (resuming), score and write the
    report (see the module docstring); the check and the job's outcome (its failed cells)."""
    given = prepare(folder, seeds_text)
    out = check_dir(folder, given.seeds)
    target = given.board.target_precision or 0.9
    job = BenchmarkJob(
        given.suite, out, given.record.methods, given.record.overrides, executor, progress, target, given.board.score
    )
    outcome = job.run(board=False)
    result = score_check(given.board, out, given.seeds)
    write_check(out, result)
    return result, outcome


__all__ = [
    "CHECK_JSON",
    "CHECK_MD",
    "CheckInput",
    "check_dir",
    "parse_seeds",
    "prepare",
    "run_check",
    "score_check",
]
