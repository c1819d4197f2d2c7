"""The demo's metric plots, checked on their figure objects: titles that fit, labelled axes, legends, no empty bins."""

from __future__ import annotations

from pathlib import Path

import pytest
from committed_results import REFERENCE
from matplotlib.figure import Figure

import roman_sim.report.plots as plots
from roman_sim.evaluation.results import read_metrics_json

DEMO = REFERENCE / "demo"
OPPOSITE = DEMO.parent / "opposite_direction"


@pytest.fixture(scope="module")
def demo_figures(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Figure]:
    if not (DEMO / "metrics.json").is_file():
        pytest.skip("no committed demo run")
    figs: dict[str, Figure] = {}
    real = plots.save_figure

    def keep(fig: Figure, path: str | Path, data: object = None) -> Path:
        out = real(fig, path, data)
        fig.canvas.draw()  # the figure as its PNG was drawn (the PDF after it is drawn at 72 dpi), kept for the checks
        figs[Path(path).name] = fig
        return out

    mp = pytest.MonkeyPatch()
    mp.setattr(plots, "save_figure", keep)
    written, skipped = plots.write_metric_plots(read_metrics_json(DEMO / "metrics.json"), tmp_path_factory.mktemp("p"))
    mp.undo()
    assert skipped == [
        "plot recall_ambiguity.png not drawn: it needs two ambiguity bins with relevant pairs; "
        "only ambiguity 0-0.25 has relevant cross-robot pairs (44)"
    ]
    assert sorted(figs) == sorted(p.name for p in written)
    return figs


def test_every_plot_is_titled_labelled_and_fits(demo_figures: dict[str, Figure]) -> None:
    assert len(demo_figures) == 6
    for name, fig in demo_figures.items():
        w, h = fig.get_size_inches()
        assert w <= 10.0 and h <= 14.0, (name, w, h)
        box = fig.bbox
        texts = [ax.title for ax in fig.axes] + ([fig._suptitle] if fig._suptitle is not None else [])
        assert any(t.get_text() for t in texts), name
        for t in texts:
            if t.get_text():
                ext = t.get_window_extent()
                assert ext.x0 >= box.x0 - 1 and ext.x1 <= box.x1 + 1, (name, t.get_text())
        for ax in fig.axes:
            assert ax.get_title() and ax.get_xlabel() and ax.get_ylabel(), name
            assert ax.get_legend() is not None, name
            if "heading" in ax.get_xlabel():
                assert ax.get_xlabel() == "heading difference (deg)"


def test_empty_heading_bins_are_not_drawn(demo_figures: dict[str, Figure]) -> None:
    """The demo has no relevant cross-robot pair below 60 deg: no 0-60 (or 0-30, 30-60) slot is drawn."""
    for name in ("recall_heading.png", "recall_operating_points.png"):
        for ax in demo_figures[name].axes:
            assert [t.get_text() for t in ax.get_xticklabels()] == ["60-120", "120-180"], name
    fine = [t.get_text() for t in demo_figures["recall_heading_fine.png"].axes[0].get_xticklabels()]
    assert fine == ["90-120", "120-150", "150-180"]  # the 4 pairs of 60-120 deg lie above 90 deg
    # association precision has data below 60 deg (associations selected on pairs that need not align)
    assoc = [t.get_text() for t in demo_figures["association_heading.png"].axes[0].get_xticklabels()]
    assert assoc == ["0-60", "60-120", "120-180"]


def test_plots_not_drawn_on_opposite_direction_are_named_with_why_in_the_report(tmp_path: Path) -> None:
    """All 51 relevant cross-robot pairs of opposite_direction lie in 120-180 deg (and one ambiguity bin):
    four plots are not drawn, and the report says which and why, each in its section."""
    from roman_sim.report.markdown import report_markdown

    if not (OPPOSITE / "metrics.json").is_file():
        pytest.skip("no committed opposite_direction run")
    metrics = read_metrics_json(OPPOSITE / "metrics.json")
    written, skipped = plots.write_metric_plots(metrics, tmp_path)
    assert [p.name for p in written] == ["precision_recall.png", "recall_heading_fine.png", "association_heading.png"]
    only = "only 120-180 deg has relevant cross-robot pairs (51)"
    assert skipped == [
        f"plot precision_recall_heading.png not drawn: it needs two heading bins with relevant pairs; {only}",
        f"plot recall_heading.png not drawn: it needs two heading bins with relevant pairs; {only}",
        "plot recall_ambiguity.png not drawn: it needs two ambiguity bins with relevant pairs; "
        "only ambiguity 0-0.25 has relevant cross-robot pairs (51)",
        f"plot recall_operating_points.png not drawn: it needs two heading bins with relevant pairs; {only}",
    ]
    text = report_markdown("opposite_direction", metrics, notes=skipped, plots=[f"plots/{p.name}" for p in written])
    head = text[text.index("## Headline plots") : text.index("## What was scored")]
    more = text[text.index("## More plots") :]
    for note in skipped:
        headline = note.startswith(("plot recall_heading.png ", "plot recall_operating_points.png "))
        assert f"- {note}" in (head if headline else more), note
    committed = (OPPOSITE / "report.md").read_text(encoding="utf-8")
    for name in ("precision_recall_heading", "recall_heading", "recall_ambiguity", "recall_operating_points"):
        assert f"- plot {name}.png not drawn: it needs two " in committed, name
