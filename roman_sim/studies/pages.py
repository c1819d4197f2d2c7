"""Generated blocks of the documentation: the reference results, the demo excerpt, the figure.

Each block sits between two HTML comment markers in a markdown page and is a pure function
of committed data, so a test re-renders it from those files and compares:

- the results page (``docs/results.md``, ``RESULTS_MARKERS``): the comparison with the
  paper, Table I, the two front ends, the ambiguity sweep and the claims, from
  ``summary.json``;
- the README's demo excerpt (``DEMO_MARKERS``): the demo's cross-robot operating points per
  method and heading bin, and its ATE, from
  the compact summary of its committed run (``results/reference/demo``);
- the README's results figure (``docs/recall_heading.png``, with a vector copy
  ``docs/recall_heading.pdf``): cross-robot max recall per heading bin of the heading sweep
  with Wilson intervals. The plotted numbers are stored in the PNG's ``roman_sim`` text
  chunk, so a test compares them with the summary without comparing pixels (which differ
  between matplotlib builds).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from roman_sim.core.atomic import write_text
from roman_sim.core.records import from_json, to_json
from roman_sim.evaluation.run_summary import RunSummary
from roman_sim.studies.claims import claims_markdown, num, point_cells, sweep_markdown, table_markdown
from roman_sim.studies.reference_tables import (
    ReferenceRecord,
    frontends_markdown,
    operating_points_markdown,
    points_header,
    revisits_markdown,
    table1_markdown,
)

RESULTS_MARKERS = ("<!-- reference-results:begin -->", "<!-- reference-results:end -->")
DEMO_MARKERS = ("<!-- demo-excerpt:begin -->", "<!-- demo-excerpt:end -->")
#: The scenario whose heading bins the README's figure shows, and the PNG chunk of its data.
FIGURE_SCENARIO = "heading_sweep"
FIGURE_KEY = "roman_sim"
#: Methods of the demo excerpt's table, in its row order (those the demo ran).
DEMO_ATE_ROWS = ("odometry", "odometry_no_prior", "roman", "visual", "combined", "oracle")


@dataclass(frozen=True)
class BinPoint:
    """One heading bin of one method in the figure: max recall, its counts and Wilson interval."""

    bin: str
    recall: float | None
    hits: int
    relevant: int
    ci: tuple[float, float] | None


@dataclass(frozen=True)
class FigureData:
    """What the README's figure shows: per method (ROMAN first), its heading bins in order."""

    scenario: str
    methods: dict[str, list[BinPoint]]


def results_block(summary: ReferenceRecord) -> str:
    """The results page's generated block (markers included)."""
    begin, end = RESULTS_MARKERS
    return (
        f"{begin}\n"
        + table_markdown(summary.comparison)
        + table1_markdown(summary.table1)
        + frontends_markdown(summary.frontends)
        + operating_points_markdown(summary.operating_points)
        + revisits_markdown(summary.revisits)
        + sweep_markdown(summary.ambiguity_sweep)
        + "\n"
        + claims_markdown(summary.claims)
        + end
    )


def demo_block(run: RunSummary) -> str:
    """The README's demo excerpt (markers included) from the demo's compact run summary.

    One row per method and heading (all cross-robot pairs, then every heading bin with relevant
    pairs), one column per operating point (``claims.pcell`` cells: recall (hits/relevant)
    [Wilson interval], P precision and k threshold at that point); then the ATE of each pose
    graph over all robots.
    """
    begin, end = DEMO_MARKERS
    methods = sorted(run.methods, key=lambda m: (m != "roman", m))
    held = {b for m in methods for b, r in run.methods[m].inter.bins.items() if r.n_relevant}
    bins = sorted(held, key=lambda b: float(b.split("-")[0]))
    lines = [begin, *points_header("method | cross-robot pairs")]
    for m in methods:
        inter = run.methods[m].inter
        for head, rec in [("all", inter.recall()), *((f"{b} deg", inter.bins.get(b)) for b in bins)]:
            lines.append(f"| {m} | {head} | " + " | ".join(point_cells(rec)) + " |")
    ate = run.ate
    rows = [f"{v} {num(ate[v].all)}" for v in DEMO_ATE_ROWS if v in ate and ate[v].all is not None]
    if rows:
        lines += ["", "ATE RMSE over both robots (m, SE(3) aligned): " + ", ".join(rows) + "."]
    return "\n".join(lines + [end])


def replace_block(text: str, markers: tuple[str, str], block: str) -> str | None:
    """``text`` with the block between ``markers`` (markers included) replaced; None without them."""
    begin, end = markers
    if begin not in text or end not in text:
        return None
    start, stop = text.index(begin), text.index(end) + len(end)
    return text[:start] + block + text[stop:]


def current_block(text: str, markers: tuple[str, str]) -> str | None:
    """The block between ``markers`` (markers included) as ``text`` holds it; None without them."""
    begin, end = markers
    if begin not in text or end not in text:
        return None
    return text[text.index(begin) : text.index(end) + len(end)]


def update_block(path: str | Path, markers: tuple[str, str], block: str) -> bool:
    """Rewrite the block of the page at ``path`` (atomically); False when it has no markers."""
    p = Path(path)
    new = replace_block(p.read_text(encoding="utf-8"), markers, block)
    if new is None:
        return False
    write_text(p, new)
    return True


def figure_data(summary: ReferenceRecord, scenario: str = FIGURE_SCENARIO) -> FigureData:
    """Per method: cross-robot max recall, hits, relevant pairs and Wilson interval per heading bin."""
    run = summary.runs.get(scenario)
    methods = {} if run is None else run.methods
    out = FigureData(scenario, {})
    for m in sorted(methods, key=lambda m: (m != "roman", m)):
        bins = methods[m].inter.bins
        out.methods[m] = [
            BinPoint(b, bins[b].max_recall, bins[b].max_hits, bins[b].n_relevant, bins[b].recall_ci)
            for b in sorted(bins, key=lambda b: float(b.split("-")[0]))
        ]
    return out


def write_figure(summary: ReferenceRecord, path: str | Path, scenario: str = FIGURE_SCENARIO) -> Path:
    """Draw ``figure_data`` as recall against heading with 95 % intervals; write the PNG and a PDF beside it
    atomically (``core.figures.save_figure``)."""
    from roman_sim.core.figures import drawn_legend, save_figure
    from roman_sim.report.plots import figure

    data = figure_data(summary, scenario)
    fig = figure(6.4, 3.6)
    ax = fig.axes[0]
    for i, (m, rows) in enumerate(data.methods.items()):
        pts = [(r.bin, r.recall, r.ci) for r in rows if r.relevant]
        shown = [(b, v, ci) for b, v, ci in pts if v is not None and ci is not None]
        x = [_centre(b) + 2.0 * (i - 2) for b, _, _ in shown]
        y = [v for _, v, _ in shown]
        err = [[v - ci[0] for _, v, ci in shown], [ci[1] - v for _, v, ci in shown]]
        ax.errorbar(
            x, y, yerr=err, marker="o", ms=4, capsize=3, color=f"C{i}", label=m, lw=2.0 if m == "roman" else 1.0
        )
    first: list[BinPoint] = next(iter(data.methods.values()), [])
    ax.set_xticks([_centre(r.bin) for r in first], [f"{r.bin} deg" for r in first])
    ax.set_xlim(0, 180)
    ax.set_ylim(0, 1.05)
    ax.set_xlabel("heading difference (relevant cross-robot pairs per bin: " + _relevant(first) + ")")
    ax.set_ylabel("max recall")
    ax.set_title(f"{scenario}: cross-robot max recall with 95 % Wilson intervals", fontsize=10)
    ax.grid(alpha=0.3)
    drawn_legend(ax, fontsize=7, ncols=len(data.methods), loc="upper center")
    return save_figure(fig, path, to_json(data), data_key=FIGURE_KEY)


def _centre(label: str) -> float:
    """The middle of a ``lo-hi`` bin label."""
    lo, hi = (float(v) for v in label.split("-"))
    return (lo + hi) / 2


def _relevant(rows: list[BinPoint]) -> str:
    return ", ".join(str(r.relevant) for r in rows)


def read_figure_data(path: str | Path) -> FigureData:
    """The data a figure written by ``write_figure`` was drawn from (its PNG text chunk; RecordError
    names the file when it holds none or another record)."""
    from roman_sim.core.figures import read_png_data

    return from_json(FigureData, read_png_data(path, FIGURE_KEY), f"{path}: text chunk {FIGURE_KEY}")
