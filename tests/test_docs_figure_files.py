"""What the docs say about the figure files holds: the evaluation page's figures section, the benchmark page's
heatmap counts, and the README figure's vector copy committed beside it."""

from __future__ import annotations

import re
from pathlib import Path

from committed_results import REFERENCE, committed_files
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import roman_sim.core.figures as figures
from roman_sim.benchmark.board_plots import short_count
from roman_sim.studies.reference import FIGURE_PNG, KEPT_PLOTS

ROOT = Path(__file__).resolve().parents[1]


def _flat(page: str) -> str:
    return " ".join((ROOT / page).read_text(encoding="utf-8").split())


def _section(page: str, heading: str) -> str:
    text = _flat(page)
    return text[text.index(heading) :].split(" ## ")[0]


def test_the_figures_section_states_the_format_the_threshold_and_the_resolution() -> None:
    text = _section("docs/evaluation.md", "### The figures")
    assert "a PDF of the same name beside it (`plots/map_view.png` and `plots/map_view.pdf`)" in text
    assert figures.VECTOR == ".pdf" and figures.PNG == ".png"
    m = re.search(r"point clouds or circle sets of more than (\d+) marks .* drawn as images at (\d+) dpi", text)
    assert m, "the page states what is drawn as an image and at what resolution"
    assert (int(m[1]), int(m[2])) == (figures.DENSE_ELEMENTS, figures.RASTER_DPI)
    assert "(`pdf.fonttype` 42," in text and b"/FontFile2" in figures.figure_files(_tiny())[".pdf"]
    meta = figures.METADATA
    assert meta[".png"]["Software"] is None and meta[".pdf"]["CreationDate"] is None
    assert meta[".pdf"]["Producer"] is None


def _tiny() -> Figure:
    fig = Figure(figsize=(2, 2))
    FigureCanvasAgg(fig)
    fig.add_subplot().set_title("x")
    return fig


def test_the_run_folder_tables_list_the_vector_copies() -> None:
    assert "| `report.md`, `plots/*.png`, `plots/*.pdf` |" in _flat("README.md")
    assert "| `plots/*.png`, `plots/*.pdf`, `report.md` |" in _flat("docs/evaluation.md")


def test_the_reference_results_keep_the_pngs_only() -> None:
    """As the figures section says: the collected plots are PNGs (a run draws the PDFs)."""
    assert "the reference results (`results/reference/`) keep the PNGs only" in _section(
        "docs/evaluation.md", "### The figures"
    )
    assert all(name.endswith(".png") for name in KEPT_PLOTS)
    assert committed_files("*.png", [REFERENCE]) and not committed_files("*.pdf", [REFERENCE])


def test_the_readme_figure_has_its_vector_copy_beside_it() -> None:
    assert "the README's figure (`docs/recall_heading.pdf`)" in _section("docs/evaluation.md", "### The figures")
    assert FIGURE_PNG.with_suffix(".pdf") == Path("docs/recall_heading.pdf")
    pdf = (ROOT / "docs" / "recall_heading.pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and pdf.count(b"/Type /Page ") == 1
    assert b"/Creator (roman_sim)" in pdf and b"/CreationDate" not in pdf


def test_the_benchmark_page_states_how_heatmap_counts_are_abbreviated() -> None:
    text = _flat("docs/benchmark.md")
    m = re.search(r"counts from ([\d ]+) on are abbreviated, `([\d.]+k)`", text)
    assert m, "the benchmark page states the abbreviation"
    start = int(m[1].replace(" ", ""))
    assert short_count(start - 1) == str(start - 1) and short_count(start) != str(start)
    assert short_count(12_345) == m[2]
