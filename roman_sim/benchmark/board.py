"""The leaderboard of a benchmark folder, from its kept raw pairs only.

Every finished cell's ``pairs.csv.gz`` is read back, relevance and correctness are
re-derived from the raw columns with the cell's ``config.yaml`` (``report.recompute.rederive_scores``), and
the pairs of all cells of one ambiguity level are pooled (pair names prefixed with the
cell). The evaluation's own ``metrics.compute_metrics`` then scores each level with the suite's
heading bins: per method and cell (level x heading bin) the operating points (max recall
with its precision, recall at precision >= 0.9 and 1, recall at the pose graph's
acceptance threshold), each with counts and a Wilson interval. In each cell the methods
are ranked by the intervals of max recall and of recall at precision >= 0.9
(``benchmark.ranking``: tied unless the intervals separate). The pooled Wilson intervals are
checked against the bound (+-0.1) per cell over every method and point (``bound_met``).

Beside them, per level, the deployable point (``benchmark.deployable``): one threshold per
method for every heading, chosen for a target precision on the level's other worlds
(leave-one-world-out over its cells), with held-out recall and precision per heading bin,
pooled Wilson and world-bootstrap intervals, and ranks by the world intervals. The suite's
headline bound is checked there (``deployable_bound_met``): in every level x heading bin the
widest world-bootstrap half-width of held-out recall, over methods, is at most +-0.1.

The deployable thresholds are chosen on one confidence score (``score``: the association count
``associations`` unless a method's own named score is chosen, ``roman-sim benchmark --score``);
on the same score, per level, each method's precision-recall curve with world intervals and the
area under it (``benchmark.board_curves``). A score a method of the folder does not offer is
refused before anything is written (``evaluation.score_curves.check_score``). The per-bin
operating points below stay on the association count (``metrics.compute_metrics``).

``leaderboard.json`` holds all of it; ``leaderboard.md`` (``benchmark.board_markdown``) and the
figures in ``plots/`` (``benchmark.board_plots``) render it. Runtimes come from each cell's
``runtimes.json``.
"""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.benchmark.board_curves import level_curves
from roman_sim.benchmark.board_markdown import RANKED, leaderboard_markdown
from roman_sim.benchmark.board_plots import write_benchmark_plots
from roman_sim.benchmark.board_records import (
    BoardCell,
    BoardLevel,
    Leaderboard,
    MethodRuntime,
    PairVerdict,
    write_leaderboard_json,
)
from roman_sim.benchmark.cells import (
    BENCHMARK_JSON,
    BENCHMARK_SCHEMA,
    CELL_JSON,
    CELLS_DIR,
    PAIRS_GZ,
    RUNTIMES_JSON,
    BenchmarkRecord,
    CellStatus,
    RuntimeStats,
)
from roman_sim.benchmark.deployable import DEFAULT_TARGET, deployable, paired_ranks
from roman_sim.benchmark.ranking import Rank
from roman_sim.benchmark.transfer import check_target
from roman_sim.core.atomic import write_text
from roman_sim.core.records import RecordError
from roman_sim.core.records import read_record as read_json_record
from roman_sim.evaluation.bins import bin_index
from roman_sim.evaluation.metrics import PairScore, compute_metrics
from roman_sim.evaluation.operating_points import POINT_NAMES, OperatingPoint
from roman_sim.evaluation.paired_worlds import MIN_HITS, paired_difference
from roman_sim.evaluation.results import read_pairs_csv
from roman_sim.evaluation.score_curves import check_score
from roman_sim.evaluation.types import CurveStats, EvaluationMetrics
from roman_sim.pipeline.scenario import method_label
from roman_sim.report.recompute import eval_settings, rederive_scores

log = logging.getLogger(__name__)

LEADERBOARD_JSON = "leaderboard.json"
LEADERBOARD_MD = "leaderboard.md"
#: Widest interval half-width the standard suite promises: of the held-out recall's world-bootstrap interval
#: at the deployable point in every level x heading bin (the headline), and of the pooled Wilson intervals of
#: the per-bin operating points.
HALF_WIDTH_BOUND = 0.1


def read_record(out: Path) -> BenchmarkRecord:
    """``benchmark.json`` of a benchmark folder (RecordError naming the file and field when missing or damaged)."""
    return read_json_record(out / BENCHMARK_JSON, BenchmarkRecord, BENCHMARK_SCHEMA)


@dataclass
class Level:
    """The pooled pairs of one ambiguity level's finished cells."""

    name: str
    knob: float
    cells: list[str] = field(default_factory=list)
    scores: list[PairScore] = field(default_factory=list)
    runtimes: list[dict[str, RuntimeStats]] = field(default_factory=list)
    acceptance_k: int | None = None


def _cell_status(out: Path, cell: str) -> str | None:
    """Why the cell has no results (its error, ``failed`` or ``pending``); None when it finished."""
    path = out / CELLS_DIR / cell / CELL_JSON
    if not path.exists():
        return "pending"
    st = read_json_record(path, CellStatus)
    return None if st.status == "ok" else st.error or st.status


def load_levels(out: Path, record: BenchmarkRecord) -> tuple[dict[str, Level], dict[str, str]]:
    """Per level its pooled, re-derived scores; and the cells that did not finish, with why."""
    levels = {lv.name: Level(lv.name, float(lv.knob)) for lv in record.levels}
    missing: dict[str, str] = {}
    for c in record.cells:
        folder = out / CELLS_DIR / c.id
        why = _cell_status(out, c.id)
        if why is not None:
            missing[c.id] = why
            continue
        cfg, acceptance_k = eval_settings(folder)
        scores, diffs = rederive_scores(read_pairs_csv(folder / PAIRS_GZ), cfg)
        if diffs:
            log.warning("cell %s: %d rows re-derived differently (%s)", c.id, len(diffs), diffs[0])
        lv = levels[c.level]
        lv.cells.append(c.id)
        lv.acceptance_k = acceptance_k
        lv.scores += [_prefixed(s, c.id) for s in scores]
        try:
            lv.runtimes.append(read_runtimes(folder / RUNTIMES_JSON))
        except RecordError as err:
            if (folder / RUNTIMES_JSON).exists():
                raise
            log.warning("%s; the cell's runtimes are left out", err)
    return levels, missing


def read_runtimes(path: Path) -> dict[str, RuntimeStats]:
    """A cell's ``runtimes.json``: per method its time per pair (RecordError naming the file and field)."""
    return read_json_record(path, dict[str, RuntimeStats])


def _prefixed(s: PairScore, cell: str) -> PairScore:
    """``s`` with its pair named ``<cell>:<a>`` / ``<cell>:<b>`` (pairs of different cells stay apart).

    Shallow copies with four fields set: ``dataclasses.replace`` gives the same records but spends a third of
    a board's reading time on its field checks (both classes are frozen and have no ``__post_init__``)."""
    t = copy.copy(s.truth)
    for name, value in (("a", f"{cell}:{t.a}"), ("b", f"{cell}:{t.b}"), ("ids_a", None), ("ids_b", None)):
        object.__setattr__(t, name, value)
    out = copy.copy(s)
    object.__setattr__(out, "truth", t)
    return out


def level_metrics(out: Path, lv: Level, edges: list[float]) -> EvaluationMetrics:
    """The evaluation of one level's pooled pairs over the suite's heading bins."""
    cfg, _ = eval_settings(out / CELLS_DIR / lv.cells[0])
    cfg = cfg.model_copy(update={"heading_bins_deg": list(edges)})
    return compute_metrics(lv.scores, cfg, 0, lv.acceptance_k)


@dataclass(frozen=True)
class MethodPairs:
    """One method's cross-robot pairs of a level as arrays: world index, heading, truth and score."""

    world: NDArray[np.int64]
    heading: NDArray[np.float64]
    hit: NDArray[np.bool_]
    relevant: NDArray[np.bool_]
    score: NDArray[np.int64]

    def world_hits(self, k: int, mask: NDArray[np.bool_], n_worlds: int) -> tuple[NDArray, NDArray]:
        """Per world the hits at threshold ``k`` and the relevant pairs among the pairs of ``mask``."""
        hit = self.hit & (self.score >= k) & mask
        return (
            np.bincount(self.world, hit, n_worlds).astype(np.float64),
            np.bincount(self.world, self.relevant & mask, n_worlds).astype(np.float64),
        )


def method_pairs(scores: list[PairScore]) -> tuple[dict[str, MethodPairs], int]:
    """Per method its cross-robot pairs of a level as arrays, and the number of worlds (cells)."""
    worlds = sorted({s.truth.a.split(":", 1)[0] for s in scores})
    at = {w: i for i, w in enumerate(worlds)}
    out = {}
    for m in dict.fromkeys(s.method for s in scores):
        rows = [s for s in scores if s.method == m and s.truth.kind == "inter"]
        out[m] = MethodPairs(
            np.asarray([at[s.truth.a.split(":", 1)[0]] for s in rows], dtype=np.int64),
            np.asarray([s.truth.heading_diff_deg for s in rows], dtype=np.float64),
            np.asarray([s.truth.relevant and s.correct for s in rows], dtype=np.bool_),
            np.asarray([s.truth.relevant for s in rows], dtype=np.bool_),
            np.asarray([s.n_assoc for s in rows], dtype=np.int64),
        )
    return out, len(worlds)


def point_ranks(
    points: dict[str, OperatingPoint | None], pairs: dict[str, MethodPairs], in_bin: Callable, n_worlds: int
) -> dict[str, Rank]:
    """Ranks at one operating point by paired verdicts over worlds (each method at its own threshold);
    a method below the floor (``MIN_HITS``) or without the point gets none."""
    counts = {}
    for m, p in points.items():
        if p is None or p.k is None or m not in pairs or p.hits < MIN_HITS:
            continue
        counts[m] = pairs[m].world_hits(p.k, in_bin(pairs[m]), n_worlds)
    if n_worlds < 2:
        return {}
    names = list(counts)
    verdicts = [
        PairVerdict(a, b, paired_difference(counts[a][0], counts[b][0], counts[a][1]).verdict, 0.0, 1.0, 0.0, 0)
        for i, a in enumerate(names)
        for b in names[i + 1 :]
    ]
    return paired_ranks(names, verdicts)


def _cell(
    label: str, stats: dict[str, CurveStats], pairs: dict[str, MethodPairs], in_bin: Callable, n_worlds: int
) -> BoardCell:
    """One leaderboard cell: per method its operating points, and the ranks by paired verdicts."""
    first = next(iter(stats.values()))
    methods: dict[str, dict[str, OperatingPoint | None]] = {
        m: {n: s.operating_points.get(n) for n in POINT_NAMES} for m, s in stats.items()
    }
    ranks = {point: point_ranks(_at(stats, point), pairs, in_bin, n_worlds) for point in RANKED}
    halves = [
        (p.recall_ci[1] - p.recall_ci[0]) / 2
        for pts in methods.values()
        for p in pts.values()
        if p is not None and p.recall_ci is not None
    ]
    return BoardCell(label, first.n_pairs, first.n_relevant, methods, ranks, max(halves) if halves else None)


def _at(stats: dict[str, CurveStats], point: str) -> dict[str, OperatingPoint | None]:
    return {m: s.operating_points.get(point) for m, s in stats.items()}


def _ambiguity_index(scores: list[PairScore]) -> float | None:
    vals = {(s.truth.a, s.truth.b): s.truth.ambiguity for s in scores if s.truth.kind == "inter"}
    finite = [v for v in vals.values() if not math.isnan(v)]
    return sum(finite) / len(finite) if finite else None


def _runtime(levels: dict[str, Level]) -> dict[str, MethodRuntime]:
    """Per method: pairs timed and the mean (exact over cells), the median and p90 of the cells' medians / p90s."""
    per: dict[str, list[RuntimeStats]] = {}
    for lv in levels.values():
        for rec in lv.runtimes:
            for m, st in rec.items():
                if st.n:
                    per.setdefault(m, []).append(st)
    out = {}
    for m, sts in sorted(per.items()):
        n = sum(s.n for s in sts)
        out[m] = MethodRuntime(
            n=n,
            mean_s=sum(float(s.mean or 0.0) * s.n for s in sts) / n,
            cell_medians_s=[float(s.median or 0.0) for s in sts],
            cell_p10_s=[s.p10 for s in sts],
            cell_p90_s=[float(s.p90 or 0.0) for s in sts],
        )
    return out


def _level(
    out: Path, lv: Level, edges: list[float], target_precision: float, score: str = DEFAULT_SCORE
) -> tuple[BoardLevel, EvaluationMetrics | None]:
    """One level's leaderboard entry and its evaluation (None before a cell of it finished)."""
    if not lv.cells:
        return BoardLevel(lv.name, lv.knob, lv.cells, lv.acceptance_k), None
    m = level_metrics(out, lv, edges)
    sets = {meth: mm.set("inter") for meth, mm in m.methods.items()}
    pairs, n_worlds = method_pairs(lv.scores)

    def bin_of(i: int) -> Callable[[MethodPairs], NDArray[np.bool_]]:
        return lambda mp: bin_index(mp.heading, edges) == i

    bins = [
        _cell(b.label, {k: v.heading_bins[i].stats for k, v in sets.items()}, pairs, bin_of(i), n_worlds)
        for i, b in enumerate(next(iter(sets.values())).heading_bins)
    ]
    k_values = eval_settings(out / CELLS_DIR / lv.cells[0])[0].k_values()
    entry = BoardLevel(
        lv.name,
        lv.knob,
        lv.cells,
        lv.acceptance_k,
        ambiguity_index=_ambiguity_index(lv.scores),
        interval_level=m.config.interval_level,
        overall=_cell(
            "all", {k: v.overall for k, v in sets.items()}, pairs, lambda mp: np.ones(len(mp.world), bool), n_worlds
        ),
        bins=bins,
        deployable=deployable(lv.scores, list(m.methods), edges, k_values, target_precision, score=score),
        curves=level_curves(lv.scores, list(m.methods), score, k_values, m.config.interval_level),
    )
    return entry, m


def leaderboard(
    out: str | Path, target_precision: float = DEFAULT_TARGET, score: str = DEFAULT_SCORE
) -> tuple[Leaderboard, dict[str, EvaluationMetrics]]:
    """The leaderboard of a benchmark folder and the evaluation of each level (for the figures).

    ``target_precision`` is the precision the deployable point's thresholds are chosen for, on the
    confidence score ``score``.

    Raises:
        EvaluationError: a method of a level that does not offer ``score`` (one line naming both).
    """
    check_target(target_precision)
    out = Path(out)
    record = read_record(out)
    edges = [float(e) for e in record.heading_edges_deg]
    levels, missing = load_levels(out, record)
    for lv in levels.values():
        check_score(lv.scores, score)
    entries, metrics = [], {}
    for name, lv in levels.items():
        entry, m = _level(out, lv, edges, target_precision, score)
        entries.append(entry)
        if m is not None:
            metrics[name] = m
    widths = [b.max_half_width for e in entries for b in e.bins]
    board = Leaderboard(
        suite=record.suite,
        description=str(record.suite_spec.get("description", "")),
        methods=[method_label(m) for m in record.methods],
        overrides=list(record.overrides),
        heading_edges_deg=edges,
        half_width_bound=HALF_WIDTH_BOUND,
        failed_cells=missing,
        levels=entries,
        bound_met=bool(widths) and all(w is not None and w <= HALF_WIDTH_BOUND for w in widths) and not missing,
        runtime=_runtime(levels),
        target_precision=target_precision,
        plugins={method_label(m): m for m in record.methods if ":" in m} or None,
        score=score,
    )
    return replace(board, deployable_bound_met=deployable_bound_met(board)), metrics


def deployable_bound_met(board: Leaderboard) -> bool:
    """Whether every cell finished and every level has held-out figures whose widest world-bootstrap recall
    half-width is at most the board's bound in every heading bin (a single-world level cannot meet it); bins
    where every method is below the floor hold no bound (``Leaderboard.deployable_floors``)."""
    widths = board.deployable_widths()
    return (
        not board.failed_cells
        and bool(widths)
        and all(len(bins) == len(board.heading_edges_deg) - 1 for bins in widths.values())
        and not board.deployable_over()
    )


def write_leaderboard(
    out: str | Path, target_precision: float = DEFAULT_TARGET, score: str = DEFAULT_SCORE
) -> list[Path]:
    """Write ``leaderboard.json``, ``leaderboard.md`` and the figures (thresholds and curves on ``score``);
    returns the paths written (nothing is written when a method does not offer ``score``)."""
    out = Path(out)
    board, metrics = leaderboard(out, target_precision, score)
    write_leaderboard_json(out / LEADERBOARD_JSON, board)
    write_text(out / LEADERBOARD_MD, leaderboard_markdown(board))
    return [out / LEADERBOARD_JSON, out / LEADERBOARD_MD, *write_benchmark_plots(board, metrics, out / "plots")]
