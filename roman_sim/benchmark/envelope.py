"""The perception envelope: one suite run with several front ends, and which verdicts hold for all of them.

A suite with ``frontends`` (``suites.FRONTENDS``: the simulated front end, the paper-calibrated
preset, the image front end that sees only pixels) runs once per front end, each a board of its
own in ``OUT/frontends/<name>/`` with the front end's scene overrides added to every cell (the
methods and their parameters stay the same: the front end is the only thing varied). The
envelope then reads the boards side by side (``envelope_rows``); the first front end is the
reference whose verdicts are stated, and each other front end either gives the same verdict
(**holds**) or not. A row holds for every front end or depends on the front end.

Rows, per level, from each board's deployable point (held-out recall, thresholds chosen on
other worlds; ``benchmark.deployable``):

- ``ranking``: every two methods over all headings: the paired verdict (``a ahead``, ``b
  ahead``, ``no difference shown``, ``too few hits``) with the difference of held-out recall.
- ``heading drop``: per method, held-out recall in the first heading bin less that in the last
  (the same robots crossing in the same and in opposite directions): ``drop`` when the two
  bins' 95 % world intervals do not overlap and the first is higher, ``rise`` when the last is,
  ``none shown`` otherwise, ``too few hits`` when both bins are below the floor.
- ``ambiguity drop`` (once, over levels): per method, held-out recall over all headings at the
  first level less that at the last, by the same rule on their world intervals.

Files: ``envelope.json`` (``Envelope``) and ``envelope.md`` in ``OUT``, written atomically.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from roman_sim.benchmark.board import LEADERBOARD_JSON
from roman_sim.benchmark.board_records import (
    BoardLevel,
    DeployableCell,
    HeldOutFigures,
    Leaderboard,
    PairVerdict,
    read_leaderboard,
)
from roman_sim.benchmark.run import BenchmarkJob, BenchmarkOutcome
from roman_sim.benchmark.suites import FRONTENDS, BenchmarkSuite
from roman_sim.core.atomic import write_text
from roman_sim.core.errors import ConfigError
from roman_sim.core.records import write_record
from roman_sim.evaluation.paired_worlds import MIN_HITS

ENVELOPE_JSON = "envelope.json"
ENVELOPE_MD = "envelope.md"
ENVELOPE_SCHEMA = "roman_sim.envelope/1"
#: Where each front end's board is kept inside an envelope's folder.
FRONTENDS_DIR = "frontends"


@dataclass(frozen=True)
class EnvelopeCell:
    """One front end's figure for one row: the verdict it gives and the figure behind it.

    Attributes:
        verdict: the verdict in this front end's board.
        figure: the figure in words (a difference with its p-value, or two recalls with their world intervals).
        holds: whether the verdict is the reference front end's.
    """

    verdict: str
    figure: str
    holds: bool


@dataclass(frozen=True)
class EnvelopeRow:
    """One headline verdict across front ends.

    Attributes:
        kind: ``ranking``, ``heading drop`` or ``ambiguity drop``.
        level: the level (``low -> high`` for the ambiguity drop).
        subject: the methods compared (``a - b``) or the method.
        stated: the reference front end's verdict.
        cells: per front end (the envelope's order) its cell.
        holds: ``holds for every front end`` or ``depends on the front end``.
    """

    kind: str
    level: str
    subject: str
    stated: str
    cells: dict[str, EnvelopeCell]
    holds: str


@dataclass(frozen=True)
class Envelope:
    """The rows of an envelope and the front ends they compare (``frontends[0]`` is the reference)."""

    suite: str
    frontends: list[str]
    rows: list[EnvelopeRow] = field(default_factory=list)


def _overall(level: BoardLevel) -> DeployableCell | None:
    d = level.deployable
    return None if d is None else d.overall


def _pair_figure(v: PairVerdict | None, a: str) -> tuple[str, str]:
    """The verdict in words and its difference signed as ``a`` less the other method (as stored either way)."""
    if v is None:
        return "n/a", "not compared"
    says = f"{v.a} ahead" if v.verdict == "a ahead" else f"{v.b} ahead" if v.verdict == "b ahead" else v.verdict
    p = "p < 0.001" if v.p_value < 0.001 else f"p {v.p_value:.3f}"
    return says, f"{(v.diff if v.a == a else -v.diff):+.3f} ({p})"


def _recall(f: HeldOutFigures | None) -> str:
    if f is None or f.recall is None:
        return "n/a"
    ci = "" if f.recall_worlds is None else f" [{f.recall_worlds[0]:.2f}, {f.recall_worlds[1]:.2f}]"
    return f"{f.recall:.2f}{ci} ({f.hits}/{f.n_relevant})"


def drop_verdict(first: HeldOutFigures | None, last: HeldOutFigures | None) -> str:
    """``drop``, ``rise``, ``none shown`` or ``too few hits`` from ``first`` to ``last`` (see the module docstring)."""
    if first is None or last is None or first.recall_worlds is None or last.recall_worlds is None:
        return "n/a"
    if first.hits < MIN_HITS and last.hits < MIN_HITS:
        return "too few hits"
    if first.recall_worlds[0] > last.recall_worlds[1]:
        return "drop"
    if last.recall_worlds[0] > first.recall_worlds[1]:
        return "rise"
    return "none shown"


def _row(kind: str, level: str, subject: str, per: dict[str, tuple[str, str]]) -> EnvelopeRow:
    names = list(per)
    stated = per[names[0]][0]
    cells = {fe: EnvelopeCell(v, fig, v == stated) for fe, (v, fig) in per.items()}
    every = all(c.holds for c in cells.values())
    return EnvelopeRow(
        kind, level, subject, stated, cells, "holds for every front end" if every else "depends on the front end"
    )


def check_boards(boards: dict[str, Leaderboard]) -> None:
    """Refuse boards that cannot be read side by side: fewer than two, other suites, levels or methods.

    Raises:
        ConfigError: one line naming the front end and what differs.
    """
    if len(boards) < 2:
        raise ConfigError(f"envelope: needs at least two front ends' boards, got {len(boards)}")
    names = list(boards)
    ref = boards[names[0]]
    for fe in names[1:]:
        b = boards[fe]
        for what, mine, theirs in (
            ("suite", ref.suite, b.suite),
            ("levels", [e.name for e in ref.levels], [e.name for e in b.levels]),
            ("methods", ref.methods, b.methods),
            ("heading bins", ref.heading_edges_deg, b.heading_edges_deg),
        ):
            if mine != theirs:
                raise ConfigError(f"envelope: front end {fe!r} has other {what} ({theirs}) than {names[0]!r} ({mine})")


def envelope_rows(boards: dict[str, Leaderboard]) -> Envelope:
    """The envelope of ``boards`` (front end -> its board, the reference first): see the module docstring."""
    check_boards(boards)
    names = list(boards)
    ref = boards[names[0]]
    rows: list[EnvelopeRow] = []
    for i, level in enumerate(ref.levels):
        per_fe = {fe: boards[fe].levels[i] for fe in names}
        cells = {fe: _overall(lv) for fe, lv in per_fe.items()}
        for j, a in enumerate(ref.methods):
            for b in ref.methods[j + 1 :]:
                per = {fe: _pair_figure(None if c is None else c.verdict(a, b), a) for fe, c in cells.items()}
                rows.append(_row("ranking", level.name, f"{a} - {b}", per))
        for m in ref.methods:
            per = {}
            for fe, lv in per_fe.items():
                bins = lv.deployable.bins if lv.deployable is not None and lv.deployable.bins else []
                first = bins[0].methods.get(m) if bins else None
                last = bins[-1].methods.get(m) if bins else None
                per[fe] = (drop_verdict(first, last), f"{_recall(first)} -> {_recall(last)}")
            rows.append(_row("heading drop", level.name, m, per))
    if len(ref.levels) >= 2:
        lo, hi = ref.levels[0].name, ref.levels[-1].name
        for m in ref.methods:
            per = {}
            for fe in names:
                c0, c1 = _overall(boards[fe].levels[0]), _overall(boards[fe].levels[-1])
                fa, fb = (None if c0 is None else c0.methods.get(m)), (None if c1 is None else c1.methods.get(m))
                per[fe] = (drop_verdict(fa, fb), f"{_recall(fa)} -> {_recall(fb)}")
            rows.append(_row("ambiguity drop", f"{lo} -> {hi}", m, per))
    return Envelope(ref.suite, names, rows)


def envelope_markdown(env: Envelope) -> str:
    """``envelope.md``: one table per kind of row, a column per front end, each cell its verdict and figure."""
    lines = [
        f"# Perception envelope of `{env.suite}`",
        "",
        f"Front ends: {', '.join(env.frontends)} (the first states the verdicts; another **holds** where it gives "
        "the same). Rows: every two methods' paired verdict on held-out recall over all headings; each method's "
        "drop from the first heading bin to the last and from the first level to the last (a drop is shown where "
        "the two 95 % world intervals do not overlap).",
        "",
    ]
    held = sum(r.holds == "holds for every front end" for r in env.rows)
    lines += [f"{held} of {len(env.rows)} verdicts hold for every front end.", ""]
    for kind in ("ranking", "heading drop", "ambiguity drop"):
        rows = [r for r in env.rows if r.kind == kind]
        if not rows:
            continue
        lines += [
            f"## {kind.capitalize()}",
            "",
            "| level | subject | " + " | ".join(env.frontends) + " | across front ends |",
            "|---|---|" + "---|" * len(env.frontends) + "---|",
        ]
        for r in rows:
            cells = [
                f"{c.verdict}: {c.figure}" + ("" if c.holds else " **differs**")
                for c in (r.cells[fe] for fe in env.frontends)
            ]
            lines.append(f"| {r.level} | {r.subject} | " + " | ".join(cells) + f" | {r.holds} |")
        lines.append("")
    return "\n".join(lines)


def run_envelope(
    suite: BenchmarkSuite,
    out: str | Path,
    methods: list[str] | None = None,
    overrides: list[str] | None = None,
    **job: Any,
) -> tuple[Envelope | None, dict[str, BenchmarkOutcome]]:
    """Run ``suite`` once per front end (each a resumable board in ``OUT/frontends/<name>/``; ``job``: the other
    arguments of ``BenchmarkJob``), then write the envelope when every board finished; the envelope (None when a
    cell failed) and each front end's outcome."""
    if not suite.frontends:
        raise ConfigError(f"suite {suite.name}: names no front ends (frontends), so it has no envelope")
    out = Path(out)
    outcomes: dict[str, BenchmarkOutcome] = {}
    for fe in suite.frontends:
        board = BenchmarkJob(suite, out / FRONTENDS_DIR / fe, methods, [*FRONTENDS[fe], *(overrides or [])], **job)
        outcomes[fe] = board.run()
    if any(o.failures for o in outcomes.values()):
        return None, outcomes
    env = envelope_rows(read_boards(out, suite.frontends))
    write_envelope(out, env)
    return env, outcomes


def read_boards(out: str | Path, frontends: list[str]) -> dict[str, Leaderboard]:
    """Each front end's finished board in ``OUT/frontends/<name>/`` (ConfigError naming a missing one)."""
    boards = {}
    for fe in frontends:
        path = Path(out) / FRONTENDS_DIR / fe / LEADERBOARD_JSON
        if not path.is_file():
            raise ConfigError(f"envelope: no board of front end {fe!r} ({path} is missing); run the suite first")
        boards[fe] = read_leaderboard(path)
    return boards


def write_envelope(out: str | Path, env: Envelope) -> list[Path]:
    """Write ``envelope.json`` and ``envelope.md`` into ``out``; the paths written."""
    out = Path(out)
    write_record(out / ENVELOPE_JSON, env, ENVELOPE_SCHEMA)
    write_text(out / ENVELOPE_MD, envelope_markdown(env))
    return [out / ENVELOPE_JSON, out / ENVELOPE_MD]


__all__ = [
    "ENVELOPE_JSON",
    "ENVELOPE_MD",
    "FRONTENDS_DIR",
    "Envelope",
    "EnvelopeCell",
    "EnvelopeRow",
    "check_boards",
    "drop_verdict",
    "envelope_markdown",
    "envelope_rows",
    "read_boards",
    "run_envelope",
    "write_envelope",
]
