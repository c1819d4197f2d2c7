"""Figure files: a PNG and a PDF beside it, the same bytes for the same figure, dense artists as images in the
PDF, data carried in the PNG, legends of drawn artists only."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import roman_sim.core.figures as figures
from roman_sim.core.figures import drawn_legend, figure_files, has_data, read_png_data, remove_figure, save_figure


def _figure(points: int = 50, title: str = "t") -> Figure:
    fig = Figure(figsize=(4.0, 3.0), dpi=90)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    xy = np.random.default_rng(0).normal(size=(points, 2))
    ax.scatter(xy[:, 0], xy[:, 1], s=1, label="points")
    ax.plot([0, 1], [0, 1], label="line")
    ax.set(title=title, xlabel="x (m)", ylabel="y (m)")
    ax.legend()
    return fig


def _images(pdf: bytes) -> int:
    return len(re.findall(rb"/Subtype /Image", pdf))


def test_a_figure_is_written_as_a_png_with_a_pdf_beside_it_and_the_same_bytes_every_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert save_figure(_figure(), tmp_path / "a" / "fig.png") == tmp_path / "a" / "fig.png"
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1000000000")  # a date PDF writers would otherwise stamp in
    save_figure(_figure(), tmp_path / "b" / "fig.png")
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["fig.pdf", "fig.png"]  # no temporary file left
    for name in ("fig.png", "fig.pdf"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
    png, pdf = (tmp_path / "a" / "fig.png").read_bytes(), (tmp_path / "a" / "fig.pdf").read_bytes()
    assert png.startswith(b"\x89PNG") and pdf.startswith(b"%PDF")
    assert b"Software" not in png and b"matplotlib" not in png.lower()
    assert b"/CreationDate" not in pdf and b"/Producer" not in pdf and b"/Creator (roman_sim)" in pdf
    assert b"/FontFile2" in pdf and b"/Type3" not in pdf  # TrueType embedded, no Type 3 fonts
    other = figure_files(_figure(title="u"))
    assert other[".png"] != png and other[".pdf"] != pdf  # the bytes follow the figure


def test_dense_artists_are_images_inside_the_pdf_and_the_png_is_unchanged(monkeypatch: pytest.MonkeyPatch) -> None:
    few, many = figure_files(_figure(points=figures.DENSE_ELEMENTS)), figure_files(_figure(points=20_000))
    assert _images(few[".pdf"]) == 0  # a small scatter stays vector
    assert _images(many[".pdf"]) >= 1  # 20 000 points: an image (and its transparency mask)
    monkeypatch.setattr(figures, "DENSE_ELEMENTS", 10**9)
    vector = figure_files(_figure(points=20_000))
    assert _images(vector[".pdf"]) == 0
    assert len(vector[".pdf"]) > 3 * len(many[".pdf"])  # 20 000 vector marks against one image
    assert vector[".png"] == many[".png"]


def test_an_image_is_an_image_in_the_pdf() -> None:
    fig = Figure(figsize=(3.0, 3.0), dpi=90)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.imshow(np.arange(12.0).reshape(3, 4))
    assert figures.rasterize_dense(fig) == 1
    assert _images(figure_files(fig)[".pdf"]) >= 1


def test_data_travels_in_the_png_and_a_pdf_path_gets_the_pdf_alone(tmp_path: Path) -> None:
    data = {"bins": ["0-60", "60-120"], "recall": [0.5, None]}
    save_figure(_figure(), tmp_path / "d.png", data)
    assert read_png_data(tmp_path / "d.png") == data
    save_figure(_figure(), tmp_path / "k.png", data, data_key="other")
    assert read_png_data(tmp_path / "k.png") is None and read_png_data(tmp_path / "k.png", "other") == data
    save_figure(_figure(), tmp_path / "only.pdf")
    assert [p.name for p in tmp_path.glob("only*")] == ["only.pdf"]
    assert (tmp_path / "only.pdf").read_bytes().startswith(b"%PDF")
    remove_figure(tmp_path / "d.png")
    assert not (tmp_path / "d.png").exists() and not (tmp_path / "d.pdf").exists()
    remove_figure(tmp_path / "d.png")  # nothing there: nothing to do


def test_a_figure_that_fails_to_render_writes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    real = figures._render

    def fail_pdf(fig: Figure, suffix: str, *args: object) -> bytes:
        if suffix == ".pdf":
            raise RuntimeError("no PDF today")
        return real(fig, suffix, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(figures, "_render", fail_pdf)
    with pytest.raises(RuntimeError, match="no PDF today"):
        save_figure(_figure(), tmp_path / "x.png")
    assert list(tmp_path.iterdir()) == []


def test_a_legend_lists_only_artists_with_data() -> None:
    fig = Figure()
    FigureCanvasAgg(fig)
    ax, other = fig.subplots(1, 2)
    ax.plot([0, 1], [0, 1], label="drawn")
    ax.plot([], [], label="empty")
    ax.plot([np.nan, np.nan], [0, 1], label="all nan")
    ax.scatter([], [], label="no points")
    ax.errorbar([], [], yerr=[[], []], label="no error bars")
    ax.bar([0], [0.0], label="a bar of height 0")  # drawn: a zero is data
    ax.plot([0, 1], [1, 0], label="drawn")  # the label again: listed once
    other.scatter([1.0], [np.nan], label="nan point")
    other.errorbar([1.0], [0.5], yerr=[[0.1], [0.1]], label="in the other panel")
    assert not has_data(ax.lines[1]) and has_data(ax.lines[0]) and has_data(ax.containers[-1])
    leg = drawn_legend(ax, fontsize=7)
    assert leg is not None and [t.get_text() for t in leg.get_texts()] == ["drawn", "a bar of height 0"]
    leg = drawn_legend(ax, [ax, other])
    assert leg is not None
    assert [t.get_text() for t in leg.get_texts()] == ["drawn", "a bar of height 0", "in the other panel"]
    empty = fig.add_subplot(2, 2, 4)
    empty.plot([], [], label="nothing")
    assert drawn_legend(empty) is None and empty.get_legend() is None
