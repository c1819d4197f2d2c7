"""Tables of the reference results: the paper's Table I, two front ends side by side, the operating points.

Both are pure functions of ``summary.json``'s ``runs`` (one ``summarize_run`` per
scenario), so a test re-derives them from the committed raw files like every other number
of the summary.

- ``table1``: per environment of the paper's Table I (tunnel, hybrid, outdoor), the paper's
  multi-robot ATE of the visual, ROMAN and combined back ends next to the simulation's rows
  odometry / odometry without start poses / visual / ROMAN / combined / oracle, each the RMSE
  over the robots every row placed, with how many robots the row placed.
- ``frontends``: the opposite-direction scenario run with the truth-driven front end and with
  the image front end: cross-robot max recall per heading bin (hits / relevant, Wilson
  interval, with its precision and threshold) of every segment-based method, and the front
  end's grades against truth.
- ``operating_points``: per recall scenario, method and heading bin with relevant pairs (and
  all cross-robot pairs), the four operating points (max recall with its precision, recall at
  precision >= 0.9 and 1 with their thresholds, recall at the acceptance threshold), each
  with hits / relevant and a Wilson interval.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from roman_sim.core.records import NONE_AS_EMPTY
from roman_sim.evaluation.run_summary import FrontEndSummary, PairCounts, RecallSummary, RunSummary
from roman_sim.studies.claims import (
    PAPER,
    PAPER_ATE,
    POINT_COLUMNS,
    Claim,
    ComparisonRow,
    PaperFigures,
    Runs,
    SweepRow,
    _ate_cell,
    _robots,
    mcell,
    num,
    point_cells,
)

#: Rows of the simulation's ATE table shown next to the paper's, with their column titles.
ATE_ROWS = {
    "odometry": "odometry",
    "odometry_no_prior": "odometry (no prior)",
    "visual": "visual",
    "roman": "ROMAN",
    "combined": "combined",
    "oracle": "oracle",
}
PAPER_ROWS = ("visual", "roman", "combined")
#: The opposite-direction scenario with each front end (truth-driven first).
FRONTEND_SCENARIOS = ("opposite_direction", "opposite_direction_pixels")
#: The scenarios of the operating points table (those whose recall the page reports), in its order.
POINT_SCENARIOS = (
    "same_direction",
    "partial_opposite",
    "opposite_direction",
    "opposite_direction_pixels",
    "heading_sweep",
)
GRADE_COLUMNS = {
    "precision": "seg. precision",
    "recall": "seg. recall",
    "mean_iou": "mean IoU",
    "over_segmented": "over-seg.",
    "under_segmented": "under-seg.",
    "cosine_same_instance": "cos same instance",
    "cosine_same_family": "cos same family",
    "cosine_other_family": "cos other family",
}


@dataclass(frozen=True)
class AteCell:
    """One simulation cell of Table I."""

    ate_m: float | None
    ate_all_m: float | None
    placed: int | None


@dataclass(frozen=True)
class Table1Row:
    """One environment of Table I: the paper's three rows and the simulation's."""

    environment: str
    scenario: str
    robots: list[str]
    common: list[str]
    paper: dict[str, float]
    simulation: dict[str, AteCell]


def table1(runs: Runs) -> list[Table1Row]:
    """One row per environment of the paper's Table I whose ``multi_robot_<env>`` scenario ran, and one
    per paper-scale ``kimera_<env>`` run present (without visual rows: those robots render no RGB).

    ``simulation[row]`` holds ``ate_m`` (SE(3) ATE RMSE over the ``common`` robots, those every
    row placed), ``ate_all_m`` (over all robots, defined only when the row placed them all) and
    ``placed`` (robots the row placed); None when undefined or when the run has no such row.
    """
    out: list[Table1Row] = []
    for env, paper in PAPER_ATE.items():
        for scen, label in ((f"multi_robot_{env}", env), (f"kimera_{env}", f"{env}, paper scale (kimera_{env})")):
            if scen not in runs:
                continue
            ate = runs[scen].ate
            robots, common = _robots(runs, scen)
            out.append(
                Table1Row(
                    environment=label,
                    scenario=scen,
                    robots=list(robots),
                    common=list(common),
                    paper=dict(zip(PAPER_ROWS, paper)),
                    simulation={
                        v: AteCell(
                            _ate_cell(ate, v, "common"),
                            _ate_cell(ate, v, "all"),
                            None if v not in ate else ate[v].connected,
                        )
                        for v in ATE_ROWS
                    },
                )
            )
    return out


def _table_cell(cell: AteCell, n: int, all_robots: bool) -> str:
    if cell.placed is None:
        return "n/a"
    return f"{num(cell.ate_all_m if all_robots else cell.ate_m)} ({cell.placed}/{n})"


def table1_markdown(rows: list[Table1Row]) -> str:
    """Table I as markdown (empty without rows)."""
    if not rows:
        return ""
    lines = [
        "",
        "## Table I: multi-robot ATE RMSE (m), the paper and the simulation",
        "",
        "Simulation cells: ATE RMSE (robots this row placed / robots), first over the robots that every row "
        "placed (last column), then over all robots (n/a for a row that did not place them all). The paper's "
        "sequences are kilometres long and these worlds 100-120 m wide: compare the orderings, not the "
        "metres.",
        "",
        "| environment | paper visual | paper ROMAN | paper combined | "
        + " | ".join(ATE_ROWS.values())
        + " | robots compared |",
        "|---" * (len(PAPER_ROWS) + len(ATE_ROWS) + 2) + "|",
    ]
    for r in rows:
        n = len(r.robots)
        cells = [num(r.paper[k]) for k in PAPER_ROWS] + [_table_cell(r.simulation[v], n, False) for v in ATE_ROWS]
        lines.append(f"| {r.environment} | " + " | ".join(cells) + f" | {', '.join(r.common) or 'none'} of {n} |")
        cells = [""] * len(PAPER_ROWS) + [_table_cell(r.simulation[v], n, True) for v in ATE_ROWS]
        lines.append(f"| {r.environment}, all robots | " + " | ".join(cells) + f" | {', '.join(r.robots)} |")
    return "\n".join(lines) + "\n"


def _label(runs: Runs, scen: str) -> str:
    fe = runs[scen].frontend if scen in runs else None
    return f"{scen} ({fe.segmenter} + {fe.encoder or 'none'})" if fe else scen


@dataclass(frozen=True)
class RecallRow:
    """One front end and method: cross-robot max recall per heading bin and overall."""

    scenario: str
    frontend: str
    method: str
    bins: dict[str, RecallSummary]
    all: RecallSummary


@dataclass(frozen=True)
class FrontEndTable:
    """The two front ends side by side."""

    scenarios: list[str]
    labels: dict[str, str]
    recall: list[RecallRow]
    grades: dict[str, FrontEndSummary | None]
    pairs: dict[str, dict[str, PairCounts]]
    same_pairs: bool


def frontends(runs: Runs) -> FrontEndTable | None:
    """The two front ends on the opposite-direction scenario (None when neither ran).

    ``recall``: one row per front end and segment-based method run by every front end's
    scenario (the visual method does not use segments), with cross-robot max recall per
    heading bin and overall. ``grades``: the front end's grades per scenario (None when the run
    did not grade it). ``same_pairs``: whether every scenario scored the same pair counts
    (all / cross-robot / same-robot, relevant and not).
    """
    from roman_sim.pipeline.scenario import VISUAL_METHODS  # imported here: it loads the simulator

    scens = [s for s in FRONTEND_SCENARIOS if s in runs]
    if not scens:
        return None
    methods = set.intersection(*(set(runs[s].methods) for s in scens)) - VISUAL_METHODS
    order = sorted(methods, key=lambda m: (m != "roman", m))
    recall = [
        RecallRow(s, _label(runs, s), m, dict(runs[s].methods[m].inter.bins), runs[s].methods[m].inter.recall())
        for m in order
        for s in scens
    ]
    pairs = [runs[s].pairs for s in scens]
    return FrontEndTable(
        scenarios=scens,
        labels={s: _label(runs, s) for s in scens},
        recall=recall,
        grades={s: runs[s].frontend for s in scens},
        pairs=dict(zip(scens, pairs)),
        same_pairs=all(p == pairs[0] for p in pairs),
    )


def _pairs_text(pairs: dict[str, PairCounts]) -> str:
    """A scenario's pair counts as the table's note shows them."""
    return str({k: {"n_pairs": c.n_pairs, "n_relevant": c.n_relevant} for k, c in pairs.items()})


def frontends_markdown(table: FrontEndTable | None) -> str:
    """The two-front-end tables as markdown (empty without data)."""
    if table is None:
        return ""
    bins = sorted({b for r in table.recall for b in r.bins}, key=lambda b: float(b.split("-")[0]))
    inter = table.pairs[table.scenarios[0]].get("inter")
    same = (
        "the same pairs in every row"
        if table.same_pairs
        else "NOT the same pair counts in every row: "
        + "; ".join(f"{s} {_pairs_text(p)}" for s, p in table.pairs.items())
    )
    lines = [
        "",
        "## Two front ends on the opposite-direction scenario",
        "",
        "`fastsam` + `simulated` cut masks from the renderer's instance image and draw descriptors from the "
        "true family and each instance's looks (truth-driven); `image` + `image` see only the RGB-D "
        "pixels. Same world, robots, pairs "
        f"and thresholds: {None if inter is None else inter.n_pairs} cross-robot pairs "
        f"({None if inter is None else inter.n_relevant} relevant), {same}. Cells: cross-robot max recall "
        "(hits/relevant) [95 % Wilson interval], P its precision and k its threshold (the other "
        "operating points: the next table).",
        "",
        "| front end | method | " + " | ".join(f"{b} deg" for b in bins) + " | all |",
        "|---" * (len(bins) + 3) + "|",
    ]
    for r in table.recall:
        lines.append(
            f"| {r.frontend} | {r.method} | " + " | ".join(mcell(r.bins.get(b)) for b in bins) + f" | {mcell(r.all)} |"
        )
    lines += [
        "",
        "Front-end grades against truth (segmentation over every graded frame; descriptor cosine means; "
        "other family: same group and other groups, weighted by pairs):",
        "",
        "| front end | frames | " + " | ".join(GRADE_COLUMNS.values()) + " |",
        "|---" * (len(GRADE_COLUMNS) + 2) + "|",
    ]
    for s in table.scenarios:
        g = table.grades[s]
        cells = (
            ["n/a"] * (len(GRADE_COLUMNS) + 1)
            if g is None
            else [num(g.frames)] + [num(getattr(g, k)) for k in GRADE_COLUMNS]
        )
        lines.append(f"| {table.labels[s]} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class PointRow:
    """One scenario, method and heading bin (``all``: every cross-robot pair): its recall and operating points."""

    scenario: str
    method: str
    heading: str
    recall: RecallSummary


def _bin_order(label: str) -> float:
    return float(label.split("-")[0])


def operating_points(runs: Runs) -> list[PointRow]:
    """Cross-robot operating points per ``POINT_SCENARIOS`` scenario that ran, method (ROMAN first)
    and heading: all pairs, then every coarse heading bin with relevant pairs in heading order."""
    rows: list[PointRow] = []
    for scen in (s for s in POINT_SCENARIOS if s in runs):
        methods = runs[scen].methods
        for m in sorted(methods, key=lambda m: (m != "roman", m)):
            inter = methods[m].inter
            rows.append(PointRow(scen, m, "all", inter.recall()))
            rows += [
                PointRow(scen, m, b, inter.bins[b])
                for b in sorted(inter.bins, key=_bin_order)
                if inter.bins[b].n_relevant
            ]
    return rows


def points_header(first: str) -> list[str]:
    """The header lines of an operating points table whose first columns are ``first``."""
    return [
        f"| {first} | " + " | ".join(POINT_COLUMNS.values()) + " |",
        "|---" * (first.count("|") + 1 + len(POINT_COLUMNS)) + "|",
    ]


POINTS_LEGEND = (
    "Cells: recall (hits/relevant) [95 % Wilson interval], then P, the precision, and k, the "
    "association threshold, at that point: max recall at the highest k that keeps its hits; recall at "
    "P>=0.9 and at P=1 at the smallest k that reaches that precision (`not reached`: no k does, recall "
    "0); recall at acceptance at the pose graph's acceptance threshold. `n<5` marks fewer than 5 "
    "relevant pairs, `P n/a` a point without a positive."
)


def operating_points_markdown(rows: list[PointRow]) -> str:
    """The operating points table as markdown (empty without rows)."""
    if not rows:
        return ""
    lines = [
        "",
        "## Operating points, cross-robot pairs",
        "",
        "Per scenario, method and heading bin with relevant pairs (`all`: every cross-robot pair). " + POINTS_LEGEND,
        "",
        *points_header("scenario | method | heading"),
    ]
    for r in rows:
        head = "all" if r.heading == "all" else f"{r.heading} deg"
        cells = point_cells(r.recall)
        lines.append(f"| {r.scenario} | {r.method} | {head} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


#: The scenarios of the revisit table, in its order: the replay first, then the revisits it is compared with.
REVISIT_SCENARIOS = (
    "same_direction_replay",
    "same_direction",
    "partial_opposite",
    "opposite_direction",
    "heading_sweep",
)


@dataclass(frozen=True)
class RevisitRow:
    """What one scenario's relevant cross-robot pairs share (``RunSummary.revisits``)."""

    scenario: str
    n_relevant: int
    median_overlap: float | None
    median_shared_objects: float | None


def revisits(runs: Runs) -> list[RevisitRow]:
    """One row per ``REVISIT_SCENARIOS`` scenario that ran and recorded its revisit figures."""
    rows: list[RevisitRow] = []
    for scen in (s for s in REVISIT_SCENARIOS if s in runs):
        fig = runs[scen].revisits
        if fig is not None:
            rows.append(RevisitRow(scen, fig.n_relevant, fig.median_overlap, fig.median_shared_objects))
    return rows


def revisits_markdown(rows: list[RevisitRow]) -> str:
    """The revisit table as markdown (empty without rows)."""
    if not rows:
        return ""
    lines = [
        "",
        "## Revisits: what relevant cross-robot pairs share",
        "",
        "Per scenario, over its relevant cross-robot submap pairs (true centres within 10 m): the median "
        "overlap (true objects with a segment in both submaps over the smaller submap's objects) and the "
        "median number of such shared objects. `same_direction_replay` drives `same_direction`'s loop as a "
        "replay (both robots on the centre line, same start and speed); `same_direction` keeps each robot "
        "to its own side of the track, starts b half way round and drives it slower.",
        "",
        "| scenario | relevant pairs | median overlap | median shared objects |",
        "|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r.scenario} | {r.n_relevant} | {num(r.median_overlap)} | {num(r.median_shared_objects, 1)} |")
    return "\n".join(lines) + "\n"


@dataclass
class ReferenceRecord:
    """``summary.json``: the runs, the comparison with the paper, Table I, the two front ends (None
    when neither ran: written as ``{}``), the operating points, the revisits, the claims, the
    ambiguity sweep's rows and the paper's figures."""

    runs: dict[str, RunSummary]
    comparison: list[ComparisonRow]
    table1: list[Table1Row] = field(default_factory=list)
    frontends: FrontEndTable | None = field(default=None, metadata=NONE_AS_EMPTY)
    operating_points: list[PointRow] = field(default_factory=list)
    revisits: list[RevisitRow] = field(default_factory=list)
    claims: list[Claim] = field(default_factory=list)
    ambiguity_sweep: list[SweepRow] = field(default_factory=list)
    paper: PaperFigures = PAPER
