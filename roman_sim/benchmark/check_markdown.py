"""``check.md``: a board's check on fresh worlds (as ``check.json`` holds it) in markdown.

First a summary (how many precision targets, fresh worlds and stated verdicts held), then per level
a table of each method's precision at its deployed threshold with every fresh world against the
board's one-new-world interval, and a table of the paired verdicts the board states with the fresh
worlds' difference, whether its sign held and what the same exact test says there.
"""

from __future__ import annotations

from roman_sim.benchmark.check_records import BoardCheck, FreshWorld, LevelCheck, PrecisionCheck, VerdictCheck


def _num(v: float | None, digits: int = 2) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def _yes(v: bool | None) -> str:
    return "n/a" if v is None else "yes" if v else "**no**"


def world_text(w: FreshWorld) -> str:
    """``low-s100 0.92 (12/13) in [10, 13]``: one fresh world's precision against the board's interval."""
    if not w.accepted:
        return f"{w.world} nothing accepted"
    text = f"{w.world} {_num(w.precision)} ({w.hits}/{w.accepted})"
    if w.hits_interval is None:
        return text + " (no interval stated)"
    lo, hi = w.hits_interval
    return text + (" in" if w.inside else " **outside**") + f" [{lo}, {hi}]"


def precision_row(level: str, p: PrecisionCheck) -> list[str]:
    """One method's row: threshold, pooled precision, target held, the stated interval, its fresh worlds."""
    inside, tested = p.inside
    stated = "none stated" if p.stated is None else f"[{p.stated[0]:.2f}, {p.stated[1]:.2f}]"
    prec = "nothing accepted" if p.precision is None else f"{p.precision:.2f} ({p.hits}/{p.hits + p.false_positives})"
    return [
        level,
        p.method,
        "none" if p.k is None else str(p.k),
        prec,
        _yes(p.target_held),
        stated,
        f"{inside} of {tested}",
        "; ".join(world_text(w) for w in p.worlds),
    ]


def verdict_row(level: str, v: VerdictCheck) -> list[str]:
    """One stated verdict's row: the board's verdict, the fresh difference, its sign and the fresh test."""
    ahead = v.a if v.stated == "a ahead" else v.b
    fresh = "n/a" if v.fresh_diff is None else f"{v.fresh_diff:+.3f} ({v.hits_a} - {v.hits_b} of {v.n_relevant})"
    test = "n/a" if v.fresh_verdict is None or v.p_value is None else f"{v.fresh_verdict} (p {v.p_value:.3f})"
    return [
        level,
        v.heading,
        f"{v.a} - {v.b}",
        f"{ahead} ahead: {v.board_diff:+.3f}",
        fresh,
        _yes(v.held),
        test,
    ]


def _table(head: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(head) + " |", "|" + "---|" * len(head), *("| " + " | ".join(r) + " |" for r in rows)]


PRECISION_HEAD = [
    "level",
    "method",
    "k",
    "fresh precision",
    "target held",
    "stated one-new-world interval",
    "worlds inside",
    "fresh worlds (hits in the interval for their accepted pairs)",
]
VERDICT_HEAD = ["level", "heading", "methods", "board", "fresh difference", "sign held", "fresh test"]


def _level_rows(levels: list[LevelCheck]) -> tuple[list[list[str]], list[list[str]], list[str]]:
    prec, verd, notes = [], [], []
    for e in levels:
        if e.note is not None:
            notes.append(f"- {e.name}: not checked ({e.note}).")
        prec += [precision_row(e.name, p) for p in e.precision]
        verd += [verdict_row(e.name, v) for v in e.verdicts]
    return prec, verd, notes


def check_readme_line(result: BoardCheck) -> str:
    """One line for the README: what the check on fresh worlds found (as ``check.md``'s summary says it)."""
    a, b = result.seeds
    held, rows = result.precision_held()
    inside, tested = result.worlds_inside()
    kept, _, stated = result.verdicts_held()
    return (
        f"- Checked on {b - a} fresh worlds per level (seeds {a}-{b - 1}) at the deployed thresholds: precision "
        f"target held in {held} of {rows} level x method rows, {inside} of {tested} fresh worlds inside the "
        f"stated one-new-world interval, {kept} of {stated} stated paired verdicts kept their sign."
    )


def check_markdown(result: BoardCheck) -> str:
    """``check.md``: summary, precision at the deployed thresholds, and the stated verdicts on fresh worlds."""
    a, b = result.seeds
    held, rows = result.precision_held()
    inside, tested = result.worlds_inside()
    kept, significant, stated = result.verdicts_held()
    prec, verd, notes = _level_rows(result.levels)
    lines = [
        f"# Check of the `{result.suite}` board on worlds it never saw (seeds {a}-{b - 1})",
        "",
        "Every level of the suite was run again at fresh seeds (the same suite definition, methods and overrides) "
        "and each fresh world scored at the board's deployed thresholds: per level and method the threshold "
        "chosen on every world of the level, not chosen again.",
        "",
        f"- Precision target ({result.target_precision:g}, held when the fresh worlds' pooled precision is at most "
        f"{result.precision_slack:g} below it): held in {held} of {rows} level x method rows.",
        f"- Fresh worlds whose hits lie in the board's one-new-world interval for the pairs they accepted: "
        f"{inside} of {tested}.",
        f"- Paired verdicts the board states that kept their sign on the fresh worlds: {kept} of {stated} "
        f"(significant there too, by the same exact sign-flip test: {significant}).",
        *(
            [f"- Fresh cells that did not finish: {', '.join(sorted(result.failed_cells))}."]
            if result.failed_cells
            else []
        ),
        *notes,
        "",
        "## Precision at the deployed thresholds",
        "",
        *_table(PRECISION_HEAD, prec),
        "",
        "## Paired verdicts the board states",
        "",
        *(_table(VERDICT_HEAD, verd) if verd else ["The board states no paired verdict (`a ahead` or `b ahead`)."]),
        "",
    ]
    return "\n".join(lines)
