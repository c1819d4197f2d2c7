"""``leaderboard.md``: a benchmark leaderboard (as ``leaderboard.json`` holds it) in markdown.

Sections: first the deployable ranking (per level, held-out recall and precision per heading
bin at one threshold per method chosen on the level's other worlds, with pooled Wilson and
world-bootstrap intervals, the thresholds and a flag where the precision falls short of the
target; first in it the headline bound, the widest world-bootstrap half-width per level x
heading bin against the suite's bound), then the setup (methods, overrides, what a cell, a
rank and an operating point are, and whether every pooled Wilson interval meets the bound),
per operating point ranked in ``RANKED`` one table per ambiguity level (methods x heading
bins, each cell ``recall (hits/relevant) [95 % interval]`` and its rank by paired verdicts,
``tied`` where no verdict separates), the relevant pairs per cell, every operating point per
level, runtimes per pair, the cells that did not finish and the figures. In the deployable
section each level also has its paired verdicts (every two methods, per heading bin: who is
ahead, or no difference shown with its power, or too few hits), its floor line (the
methods with too few held-out hits to rank) and, beside the deployable point, the area under
each method's precision-recall curve on the board's score with its world interval
(``auc_table``); its held-out precision table ends with each method's one-new-world precision
interval (``board_records.PrecisionSpread``). Thresholds on the association count print as
``k``; on a named score the section says which score they are of.
"""

from __future__ import annotations

from dataclasses import replace

from roman_sim.align.base import DEFAULT_SCORE
from roman_sim.benchmark.board_curves import AucVerdict, LevelCurves
from roman_sim.benchmark.board_plots import benchmark_figures
from roman_sim.benchmark.board_records import (
    BoardCell,
    Deployable,
    DeployableCell,
    HeldOutFigures,
    Leaderboard,
    PairVerdict,
    PrecisionSpread,
)
from roman_sim.benchmark.check_markdown import check_readme_line
from roman_sim.benchmark.check_records import BoardCheck
from roman_sim.benchmark.ranking import Rank
from roman_sim.evaluation.bins import bin_label
from roman_sim.evaluation.operating_points import POINT_LABELS, POINT_NAMES, OperatingPoint
from roman_sim.evaluation.paired_worlds import MIN_HITS

#: The operating points methods are ranked by, in each cell.
RANKED = ("max_recall", "precision_90")


def _rate(p: OperatingPoint | None) -> str:
    if p is None or not p.n_relevant:
        return "n/a"
    if not p.reached or p.recall is None or p.recall_ci is None:
        return f"not reached (0/{p.n_relevant})"
    lo, hi = p.recall_ci
    return f"{p.recall:.2f} ({p.hits}/{p.n_relevant}) [{lo:.2f}, {hi:.2f}]"


def _rate_at(p: OperatingPoint | None) -> str:
    """``_rate`` with the operating point's precision and threshold (``P 0.76 k 3``) where it has them."""
    out = _rate(p)
    if p is not None and p.n_relevant and p.reached and p.precision is not None:
        out += f" P {p.precision:.2f} k {p.k}"
    return out


def _ranked_cell(cell: BoardCell, method: str, point: str) -> str:
    r = cell.ranks[point].get(method)
    p = cell.point(method, point)
    rank = "" if r is None else (f" tied {r.rank}" if r.tied else f" #{r.rank}")
    if r is None and p is not None and p.n_relevant and p.reached and p.hits < MIN_HITS:
        rank = ", too few hits to rank"
    return _rate(p) + rank


def _rank_tables(board: Leaderboard, point: str) -> list[str]:
    lines = []
    for e in board.finished_levels():
        cells = e.all_cells()
        lines += [
            f"**{e.name}** (knob {e.knob:g}, measured ambiguity index {_num(e.ambiguity_index)}):",
            "",
            "| method | " + " | ".join(f"{c.heading} deg" if c.heading != "all" else "all" for c in cells) + " |",
            "|---|" + "---|" * len(cells),
        ]
        for m in board.methods:
            if e.overall is not None and m in e.overall.methods:
                lines.append(f"| {m} | " + " | ".join(_ranked_cell(c, m, point) for c in cells) + " |")
        lines.append("")
    return lines


def _method_list(board: Leaderboard) -> str:
    """The methods by their rows' labels, each plug-in followed by its ``package.module:Class``."""
    plugins = board.plugins or {}
    return ", ".join(f"{m} (`{plugins[m]}`)" if m in plugins else m for m in board.methods)


def _rp(p: OperatingPoint) -> str:
    """A point's recall with its precision (``0.46 P 0.40``; the recall alone where nothing was accepted)."""
    return _num(p.recall) + ("" if p.precision is None or not p.reached else f" P {p.precision:.2f}")


def _num(v: float | None, digits: int = 2) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def _bin_width(board: Leaderboard) -> str:
    """The heading bins' width (``60``), or their edges when they are uneven."""
    e = board.heading_edges_deg
    widths = {round(b - a, 9) for a, b in zip(e, e[1:], strict=False)}
    return f"{widths.pop():g}" if len(widths) == 1 else "edges " + ", ".join(f"{x:g}" for x in e)


def _widest(cell: DeployableCell) -> str:
    """``0.087 (roman)``: the widest world-bootstrap recall half-width of a bin and the method with it."""
    if cell.max_half_width is None:
        return "n/a"
    halves = {m: (c.recall_worlds[1] - c.recall_worlds[0]) / 2 for m, c in cell.methods.items() if c.recall_worlds}
    m = max(sorted(halves), key=lambda k: halves[k])
    return f"{cell.max_half_width:.3f} ({m})"


def deployable_bound_lines(board: Leaderboard) -> list[str]:
    """The headline bound: per level x heading bin the widest world-bootstrap half-width of held-out recall."""
    bound = board.half_width_bound
    verdict = "met" if board.deployable_bound_met else "**not met**"
    lines = [
        f"Deployable bound: in every level x heading bin the widest 95 % world-bootstrap half-width of held-out "
        f"recall, over methods, at most {bound:g}: {verdict}.",
        "",
        "| level | "
        + " | ".join(
            f"{bin_label(a, b)} deg" for a, b in zip(board.heading_edges_deg, board.heading_edges_deg[1:], strict=False)
        )
        + " |",
        "|---|" + "---|" * (len(board.heading_edges_deg) - 1),
    ]
    floors = set(board.deployable_floors())
    for e in board.levels:
        d = e.deployable
        if d is None or d.bins is None:
            why = "no cell finished" if d is None else f"no held-out figures ({len(d.worlds)} world)"
            lines.append(f"| {e.name} | " + " | ".join([why] * (len(board.heading_edges_deg) - 1)) + " |")
            continue
        cells = [
            "floor: every method has too few hits"
            if (e.name, c.heading) in floors
            else _widest(c) + ("" if c.max_half_width is not None and c.max_half_width <= bound else " **over**")
            for c in d.bins
        ]
        lines.append(f"| {e.name} | " + " | ".join(cells) + " |")
    if floors:
        lines += [
            "",
            "Bins where every method is below the floor hold no bound: "
            + ", ".join(f"{lv} {h} deg" for lv, h in sorted(floors))
            + " (a floor is a finding: no method aligns enough there to rank or bound).",
        ]
    return [*lines, ""]


def leaderboard_markdown(board: Leaderboard) -> str:
    """``leaderboard.md``: deployable ranking, setup, ranked recall per cell, points, runtimes, failures, figures."""
    lv0 = next(iter(board.finished_levels()), None)
    acc = None if lv0 is None else lv0.acceptance_k
    lines = [
        f"# Benchmark `{board.suite}`",
        "",
        board.description + ".",
        "",
        *_deployable_section(board),
        "## Setup",
        "",
        f"- Methods: {_method_list(board)}. Overrides: {', '.join(board.overrides) or 'none'}.",
        f"- Cells: ambiguity level x heading difference ({_bin_width(board)} deg bins) of the cross-robot pairs, "
        "pooled over the level's seeds; counts are hits / relevant pairs with 95 % Wilson intervals.",
        "- Ranks: 1 + the number of methods a paired verdict puts ahead (each method at its own threshold, "
        "compared world by world on the same relevant pairs); methods that share a rank are marked `tied`; a "
        f"method with fewer than {MIN_HITS} hits in a cell is not ranked there.",
        f"- Operating points: max recall (at the highest k that keeps it); recall at the smallest k with precision "
        f">= 0.9 (`not reached` when none has); recall at the pose graph's acceptance threshold k = {acc}.",
        f"- Wilson bound (per-bin operating points below): every pooled Wilson half-width at most "
        f"{board.half_width_bound:g}: "
        + ("met in every cell." if board.bound_met else "**not met** in every cell (see the relevant counts)."),
        "",
    ]
    lines += [
        "The sections below read each cell's own precision-recall sweep: a threshold per heading bin, chosen "
        "with that bin's truth (an upper bound no deployed system reaches); max recall is the secondary column "
        "of the deployable ranking."
        + (
            ""
            if board.score == DEFAULT_SCORE
            else f" Their thresholds are on the association count k (the pose graph accepts a closure by it), "
            f"not on `{board.score}`, which the deployable point and the curves are on."
        ),
        "",
    ]
    for point in RANKED:
        label = POINT_LABELS[point]
        lines += [f"## {label[0].upper()}{label[1:]}, ranked", "", *_rank_tables(board, point)]
    lines += ["## Relevant cross-robot pairs per cell", "", *_relevant_table(board), ""]
    lines += ["## Operating points per level", "", *_points_table(board, acc), ""]
    lines += ["## Runtime per pair", "", *_runtime_table(board), ""]
    if board.failed_cells:
        lines += ["## Cells that did not finish", ""]
        lines += [f"- `{c}`: {err}" for c, err in sorted(board.failed_cells.items())] + [""]
    lines += ["## Figures", ""] + [f"![{cap}](plots/{name})" for name, cap in benchmark_figures(board).items()] + [""]
    return "\n".join(lines)


def _ci(ci: list[float] | None) -> str:
    return "n/a" if ci is None else f"[{ci[0]:.2f}, {ci[1]:.2f}]"


def _held_out_recall(c: HeldOutFigures | None, rank: Rank | None, floor: str | None = None) -> str:
    """``recall (hits/relevant) Wilson [..] worlds [..] #rank`` of one held-out cell (the floor instead of a rank)."""
    if c is None or not c.n_relevant:
        return "n/a"
    out = f"{c.recall:.2f} ({c.hits}/{c.n_relevant})"
    out += f" Wilson {_ci(c.recall_wilson)} worlds {_ci(c.recall_worlds)}"
    if floor is not None:
        out += f", {floor}"
    elif rank is not None:
        out += f" tied {rank.rank}" if rank.tied else f" #{rank.rank}"
    return out


def _signed(x: float) -> str:
    return f"{x:+.3f}"


def _p(p: float) -> str:
    return "p < 0.001" if p < 0.001 else f"p {p:.3f}"


def verdict_text(v: PairVerdict, effect: float) -> str:
    """One paired verdict as the leaderboard prints it: the verdict, the difference and its p-value."""
    if v.verdict == "too few hits":
        return "too few hits"
    return f"{v.says(effect)}: {_signed(v.diff)} ({_p(v.p_value)})"


def floor_lines(d: Deployable) -> list[str]:
    """The level's floor: per heading bin the methods with too few held-out hits to rank."""
    per = [f"{c.heading} deg: " + "; ".join(f"{m} {t}" for m, t in c.floor.items()) for c in d.cells() if c.floor]
    head = f"Floor: fewer than {d.min_hits} held-out hits in a bin is too few to rank (no rank, counts toward no bound)"
    return [head + (": " + " | ".join(per) + "." if per else ": no method is below it."), ""]


def verdict_table(d: Deployable, methods: list[str]) -> list[str]:
    """Every two methods' paired verdicts per heading bin (the difference of held-out recall, ``a`` less ``b``)."""
    effect = d.effect if d.effect is not None else 0.05
    cells = d.cells()
    heads = [f"{c.heading} deg" if c.heading != "all" else "all" for c in cells]
    lines = [
        f"Paired verdicts (held-out recall of the first less the second, same worlds and pairs; exact two-sided "
        f"sign-flip test over worlds at 0.05; power for a difference of {effect:g}):",
        "",
        "| methods | " + " | ".join(heads) + " |",
        "|---|" + "---|" * len(cells),
    ]
    for i, a in enumerate(methods):
        for b in methods[i + 1 :]:
            got = [c.verdict(a, b) for c in cells]
            if all(v is None for v in got):
                continue
            row = ["n/a" if v is None else verdict_text(v if v.a == a else _flipped(v), effect) for v in got]
            lines.append(f"| {a} - {b} | " + " | ".join(row) + " |")
    return [*lines, ""]


def _flipped(v: PairVerdict) -> PairVerdict:
    """The verdict with its two methods swapped (the difference negated)."""
    swap = {"a ahead": "b ahead", "b ahead": "a ahead"}
    return replace(v, a=v.b, b=v.a, verdict=swap.get(v.verdict, v.verdict), diff=-v.diff)


def _held_out_precision(c: HeldOutFigures | None) -> str:
    """``precision worlds [..]`` of one held-out cell, ``short`` when it falls short of the target."""
    if c is None or c.precision is None:
        return "nothing accepted"
    return f"{c.precision:.2f} worlds {_ci(c.precision_worlds)}" + ("" if c.transfers else " **short**")


def threshold_text(k: float | None) -> str:
    """A deployable threshold as the board prints it: ``none``, an int as it is, a float to 4 significant digits."""
    if k is None:
        return "none"
    return str(k) if isinstance(k, int) else f"{k:.4g}"


def auc_table(curves: LevelCurves | None, methods: list[str]) -> list[str]:
    """A level's threshold-free summary: per method the area under its precision-recall curve on the board's
    score, with its world interval."""
    if curves is None:
        return []
    lines = [
        f"Area under the precision-recall curve on `{curves.score}` (cross-robot pairs of every heading, pooled over "
        f"the level's worlds; every threshold, none chosen; 95 % world bootstrap, {curves.draws} draws):",
        "",
        "| method | AUC [world interval] |",
        "|---|---|",
    ]
    names = [m for m in methods if m in curves.methods]
    for m in names:
        c = curves.methods[m]
        lines.append(f"| {m} | {_num(c.auc, 3)} {_ci3(c.auc_worlds)} |")
    lines.append("")
    if curves.verdicts:
        lines += [
            "Paired area verdicts (each world's own area, the first less the second, over the worlds where both have "
            "one; exact two-sided sign-flip test over worlds on differences rounded to 0.001, at 0.05):",
            "",
        ]
        for i, a in enumerate(names):
            for b in names[i + 1 :]:
                v = curves.verdict(a, b)
                if v is not None:
                    lines.append(f"- {a} - {b}: {auc_verdict_text(v if v.a == a else _auc_flipped(v))}")
        lines.append("")
    return lines


def auc_verdict_text(v: AucVerdict) -> str:
    """One paired area verdict in words: the method ahead (or none shown), the mean difference, p and worlds."""
    if v.verdict == "too few hits":
        return "too few hits"
    says = f"{v.a} ahead" if v.verdict == "a ahead" else f"{v.b} ahead" if v.verdict == "b ahead" else v.verdict
    diff = "n/a" if v.diff is None else _signed(v.diff)
    return f"{says}: {diff} ({_p(v.p_value)}, {v.worlds} worlds)"


def _auc_flipped(v: AucVerdict) -> AucVerdict:
    swap = {"a ahead": "b ahead", "b ahead": "a ahead"}
    return replace(v, a=v.b, b=v.a, verdict=swap.get(v.verdict, v.verdict), diff=None if v.diff is None else -v.diff)


def _ci3(ci: list[float] | None) -> str:
    return "n/a" if ci is None else f"[{ci[0]:.3f}, {ci[1]:.3f}]"


def spread_text(s: PrecisionSpread | None) -> str:
    """A method's one-new-world precision interval and the beta fit it comes from."""
    if s is None:
        return "n/a (fewer than two worlds accepted a pair)"
    return f"{_ci(s.interval)} (Beta({s.a:.3g}, {s.b:.3g}) over {s.worlds} worlds)"


def _deployable_section(board: Leaderboard) -> list[str]:
    """The leaderboard's lead: per level, held-out recall and precision at one threshold chosen on other worlds."""
    target = board.target_precision
    if target is None:
        return []
    on = (
        "one association threshold k" if board.score == DEFAULT_SCORE else f"one threshold on the score `{board.score}`"
    )
    own = (
        ""
        if board.score == DEFAULT_SCORE
        else " (chosen among the calibration pairs' own values of the score; a pair without it is accepted at "
        "no threshold)"
    )
    lines = [
        f"## Deployable ranking: held-out recall at target precision {target:g}",
        "",
        f"- Thresholds: per method and level {on} for every heading, chosen on the "
        f"other worlds (seeds) of the level: the smallest {'k' if board.score == DEFAULT_SCORE else 'threshold'} "
        f"whose precision over all their cross-robot pairs "
        f"is at least {target:g} (leave-one-world-out){own}. Each world is scored at the threshold chosen without "
        f"it; the held-out counts are pooled over the level's worlds.",
        "- Intervals: pooled 95 % Wilson, and 95 % world bootstrap (draw worlds with replacement, each drawn "
        "world's pairs kept whole; draws doubled until no bound or verdict depends on the bootstrap's seed). "
        "With few worlds per level the world bootstrap is crude: it can only draw combinations of those worlds.",
        "- Ranks: from paired verdicts. Every two methods are compared on the same worlds and relevant pairs: the "
        "difference of their held-out recall, tested by the exact sign-flip test over worlds (each world's "
        "difference as likely + as -; nothing is drawn at random, so no verdict depends on a seed). A method's "
        "rank is 1 + the methods ahead of it; `tied` where no verdict separates. A method with too few held-out "
        "hits in a bin is not ranked there and counts toward no bound (the floor line says which).",
        f"- Flag: **short** where the held-out precision is more than 0.05 below {target:g} (the threshold "
        "does not transfer to a new world); `nothing accepted` where no threshold reached the target.",
        "- One new world: per method the central 95 % interval of one new world's precision over all headings, "
        "from a beta-binomial fit of the held-out worlds' precisions (each world's held-out hits out of its "
        "accepted pairs; a world's precision a draw of Beta(a, b)). A new world that accepts n pairs adds its "
        "own binomial noise: `roman-sim benchmark check` tests each fresh world's hits against the fit's "
        "interval for its n.",
        "",
        *deployable_bound_lines(board),
    ]
    for e in board.levels:
        d = e.deployable
        if d is None:
            continue
        lines += [f"**{e.name}** (knob {e.knob:g}, worlds {', '.join(d.worlds) or 'none'}):", ""]
        if d.note is not None:
            lines += [f"No held-out figures: {d.note}.", ""]
            continue
        cells = d.cells()
        heads = [f"{c.heading} deg" if c.heading != "all" else "all" for c in cells]
        lines += [
            "| method | "
            + " | ".join(heads)
            + f" | thresholds (held-out world: {'k' if board.score == DEFAULT_SCORE else board.score}) "
            + "| max recall (all) |",
            "|---|" + "---|" * (len(cells) + 2),
        ]
        thresholds = d.thresholds or {}
        for m in board.methods:
            if m not in thresholds:
                continue
            ks = ", ".join(f"{w}: {threshold_text(k)}" for w, k in thresholds[m].items())
            mx = None if e.overall is None else e.overall.point(m, "max_recall")
            row = [_held_out_recall(c.methods.get(m), c.ranks.get(m), c.floor.get(m)) for c in cells]
            lines.append(f"| {m} | " + " | ".join(row) + f" | {ks} | {_rate(mx)} |")
        lines += [
            "",
            "| held-out precision | " + " | ".join(heads) + " | one new world (95 %) |",
            "|---|" + "---|" * (len(cells) + 1),
        ]
        spread = d.spread or {}
        for m in board.methods:
            if m in thresholds:
                row = [_held_out_precision(c.methods.get(m)) for c in cells]
                lines.append(f"| {m} | " + " | ".join(row) + f" | {spread_text(spread.get(m))} |")
        lines.append("")
        lines += floor_lines(d)
        lines += verdict_table(d, [m for m in board.methods if m in thresholds])
        lines += auc_table(e.curves, board.methods)
    return lines


def _relevant_table(board: Leaderboard) -> list[str]:
    named = board.finished_levels()
    if not named:
        return ["No cell finished."]
    heads = [b.heading for b in named[0].bins]
    out = [
        "| level | " + " | ".join(f"{h} deg" for h in heads) + " | cross-robot pairs scored |",
        "|---|" + "---|" * (len(heads) + 1),
    ]
    for e in named:
        n_pairs = None if e.overall is None else e.overall.n_pairs
        out.append(f"| {e.name} | " + " | ".join(str(b.n_relevant) for b in e.bins) + f" | {n_pairs} |")
    return out


def _points_table(board: Leaderboard, acc: int | None) -> list[str]:
    out = [
        f"| level | method | max recall (precision) | {POINT_LABELS['precision_90']} (k) | "
        f"{POINT_LABELS['precision_100']} (k) | recall at k = {acc} (precision) |",
        "|---|---|---|---|---|---|",
    ]
    for e in board.levels:
        for m, pts in ({} if e.overall is None else e.overall.methods).items():
            cells = []
            for name in POINT_NAMES:
                p = pts[name]
                extra = ""
                if p is not None and p.reached:
                    extra = f" P={_num(p.precision)}" if name in ("max_recall", "acceptance") else f" k={p.k}"
                cells.append(_rate(p) + extra)
            out.append(f"| {e.name} | {m} | " + " | ".join(cells) + " |")
    return out


def _runtime_table(board: Leaderboard) -> list[str]:
    if not board.runtime:
        return ["No runtimes were recorded."]
    out = ["| method | pairs timed | mean ms | median ms (cells) | p90 ms (cells) |", "|---|---|---|---|---|"]
    for m, r in board.runtime.items():
        med = sorted(r.cell_medians_s)
        out.append(
            f"| {m} | {r.n} | {1000 * r.mean_s:.1f} | {1000 * med[len(med) // 2]:.1f} | "
            f"{1000 * max(r.cell_p90_s):.1f} |"
        )
    return out


#: Markers of the README's benchmark block (``readme_block``).
README_BEGIN, README_END = "<!-- benchmark:begin -->", "<!-- benchmark:end -->"


def _first_alone(board: Leaderboard, method: str, point: str) -> tuple[int, int, int]:
    """(cells where ``method`` ranks first alone, first but tied, cells with a rank) over every level x bin."""
    alone = tied = ranked = 0
    for e in board.levels:
        for b in e.bins:
            r = b.ranks[point].get(method)
            if r is None:
                continue
            ranked += 1
            alone += r.rank == 1 and not r.tied
            tied += r.rank == 1 and r.tied
    return alone, tied, ranked


def deployable_readme_lines(board: Leaderboard) -> list[str]:
    """The README's statements of the deployable ranking, one line per level (all headings)."""
    target = board.target_precision
    if target is None:
        return []
    lines = [
        f"- Deployable ranking (one threshold per method and level for every heading, chosen on the other "
        f"worlds for precision >= {target:g}; held-out recall over all headings, ranked by paired verdicts over "
        f"the same worlds; a method with too few held-out hits is a floor, not a rank):"
    ]
    for e in board.levels:
        d = e.deployable
        if d is None:
            continue
        if d.note is not None or d.overall is None:
            lines.append(f"  - {e.name}: {d.note or 'no held-out figures'}.")
            continue
        parts = []
        for m, c, r in d.overall.order():
            rank = f"tied {r.rank}" if r.tied else f"#{r.rank}"
            prec = "nothing accepted" if c.precision is None else f"P {c.precision:.2f}"
            flag = "" if c.transfers else ", short of the target"
            parts.append(f"{rank} {m} {_num(c.recall)} ({c.hits}/{c.n_relevant}, {prec}{flag})")
        parts += [f"{m} {t}" for m, t in d.overall.floor.items()]
        lines.append(f"  - {e.name}: " + "; ".join(parts) + ".")
    return lines


def _ahead_of_all(curves: LevelCurves) -> bool:
    """Whether the method with the largest area is ahead of every other one by its paired area verdict."""
    got = [(m, c.auc) for m, c in curves.methods.items() if c.auc is not None]
    if len(got) < 2:
        return False
    top = max(got, key=lambda x: (x[1], x[0]))[0]
    mine = [v for v in curves.verdicts if top in (v.a, v.b)]
    wins = [v for v in mine if (v.verdict == "a ahead" and v.a == top) or (v.verdict == "b ahead" and v.b == top)]
    return len(mine) == len(got) - 1 and len(wins) == len(mine)


def auc_readme_line(board: Leaderboard, first: int = 2) -> str | None:
    """The README's statement of the threshold-free summary: per level the ``first`` methods by area under the
    precision-recall curve on the board's score, with their world intervals (None without curves)."""
    parts = []
    for e in board.levels:
        if e.curves is None:
            continue
        got = sorted(
            ((m, c) for m, c in e.curves.methods.items() if c.auc is not None), key=lambda x: (-(x[1].auc or 0.0), x[0])
        )
        parts.append(f"{e.name} " + ", ".join(f"{m} {_num(c.auc)} {_ci(c.auc_worlds)}" for m, c in got[:first]))
    if not parts:
        return None
    ahead = [e.name for e in board.levels if e.curves is not None and _ahead_of_all(e.curves)]
    said = (
        f" The first's area is ahead of every other method's by the paired area verdicts at: {', '.join(ahead)}."
        if ahead
        else ""
    )
    return (
        f"- Area under the precision-recall curve on `{board.score}` (every threshold, none chosen; 95 % world "
        f"interval), the first {first} per level: " + "; ".join(parts) + "." + said
    )


def deployable_bound_readme_line(board: Leaderboard) -> str:
    """The README's statement of the headline bound, with the widest bin (or the bins over it)."""
    head = (
        f"- Deployable world-bootstrap half-width of held-out recall at most {board.half_width_bound:g} in every "
        f"level x heading bin: "
    )
    per_level = board.deployable_widths()
    floors = board.deployable_floors()
    floor_note = (
        f"; floors, every method below {MIN_HITS} held-out hits, hold no bound: "
        + ", ".join(f"{lv} {h} deg" for lv, h in floors)
        if floors
        else ""
    )
    if board.deployable_bound_met:
        widths = [(lv, h, w) for lv, bins in per_level.items() for h, w in bins.items() if (lv, h) not in floors]
        lv, h, w = max(widths, key=lambda x: x[2] or 0.0)
        return head + f"yes (widest {_num(w, 3)}, {lv} {h} deg{floor_note})."
    parts = [f"{lv} {h} deg {_num(w, 3)}" for lv, h, w in board.deployable_over()]
    parts += [f"{lv} without held-out figures" for lv, bins in per_level.items() if not bins]
    if board.failed_cells:
        parts.append(f"{len(board.failed_cells)} cells did not finish")
    return head + ("no (" + "; ".join(parts) + f"{floor_note})." if parts else "no.")


def readme_block(board: Leaderboard, figure: str, check: BoardCheck | None = None) -> str:
    """The README's benchmark block: the recall-against-heading figure and statements read off ``board`` (and
    the line of its ``check`` on fresh worlds, when given).

    Every number is the board's (a test renders this again from the committed raw pairs).
    """
    lines = [README_BEGIN, "", f"![{benchmark_figures(board)['recall_heading.png']}]({figure})", ""]
    lines += deployable_readme_lines(board)
    lines += [x for x in [auc_readme_line(board)] if x is not None]
    m = "roman" if "roman" in board.methods else board.methods[0]
    per_level = []
    for e in board.finished_levels():
        parts = []
        for point in ("max_recall", "precision_90"):
            pts = [(b.heading, p) for b in e.bins if (p := b.point(m, point)) is not None]
            lo = min(pts, key=lambda x: x[1].recall if x[1].recall is not None else 2.0)
            hi = max(pts, key=lambda x: x[1].recall if x[1].recall is not None else -1.0)
            parts.append(f"{_rp(lo[1])} ({lo[0]}) to {_rp(hi[1])} ({hi[0]})")
        per_level.append(f"{e.name} (index {_num(e.ambiguity_index)}) " + ", ".join(parts))
    if per_level:
        lines.append(
            f"- {m} over the heading bins, lowest to highest (max recall, then recall at P>=0.9; per-bin "
            "thresholds, an upper bound): " + "; ".join(per_level) + "."
        )
    for point in RANKED:
        alone, tied, ranked = _first_alone(board, m, point)
        lines.append(
            f"- {POINT_LABELS[point]}: {m} ranks first alone in {alone} of {ranked} cells and is tied for first in "
            f"{tied} (ranked by paired verdicts over worlds)."
        )
    lines += [] if check is None else [check_readme_line(check)]
    lines += [
        deployable_bound_readme_line(board),
        f"- Every pooled Wilson half-width of the per-bin operating points at most {board.half_width_bound:g}: "
        f"{'yes' if board.bound_met else 'no'}.",
        "",
        README_END,
    ]
    return "\n".join(lines)
