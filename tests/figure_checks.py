"""Checks of a matplotlib figure as it is saved, shared by the tests of the report's plots and the benchmark's.

``Saved`` watches ``Figure.savefig`` (and the legends made meanwhile), so each figure is checked
as it is saved: ``check_figure`` (a title, labelled axes with units on maps, a legend or colour
bar, every text inside the saved image, a size a page can hold and no text below 6 points; maps
drawn to scale), ``legend_problems`` (legend entries that list nothing drawn) and
``text_overlaps`` (texts closer than ``TEXT_GAP_PT``).
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.collections import Collection, PathCollection
from matplotlib.colors import to_rgba, to_rgba_array
from matplotlib.container import Container
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.text import Text
from matplotlib.transforms import Bbox

#: Largest figure (inches): two columns of a page at most.
MAX_W, MAX_H = 12.0, 14.0
#: Maps: figures whose axes show metres in x and y.
MAPS = ("map_view.png", "trajectories.png", "alignment_")


class Saved:
    """The figures saved while it watches ``Figure.savefig``, each once with the area its PNG shows (the tight
    bounding box for ``bbox_inches="tight"``, else the figure), and the handles every legend made meanwhile was
    given (``legend_handles``)."""

    def __init__(self) -> None:
        self.figures: list[tuple[Figure, Bbox]] = []
        self.legends: list[tuple[Legend, list[Any]]] = []
        self.formats: dict[int, list[str]] = {}

    def watch(self, mp: pytest.MonkeyPatch) -> None:
        real, real_legend = Figure.savefig, Legend.__init__
        seen, legends, formats = self.figures, self.legends, self.formats

        def savefig(fig: Figure, fname: Any, *args: Any, **kwargs: Any) -> Any:
            out = real(fig, fname, *args, **kwargs)  # lays the figure out as saved
            fmt = kwargs.get("format") or Path(str(fname)).suffix[1:]
            formats.setdefault(id(fig), []).append(fmt)
            if fmt == "png":
                renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
                tight = kwargs.get("bbox_inches") == "tight"
                area = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans) if tight else fig.bbox
                seen.append((fig, area))
            return out

        def legend(leg: Legend, parent: Any, handles: Any, labels: Any, *args: Any, **kwargs: Any) -> None:
            legends.append((leg, list(handles)))
            real_legend(leg, parent, handles, labels, *args, **kwargs)

        mp.setattr(Figure, "savefig", savefig)
        mp.setattr(Legend, "__init__", legend)

    def one(self) -> tuple[Figure, Bbox]:
        """The one figure saved since the last call (saved as a PNG and then a PDF), laid out again as its PNG."""
        ((fig, area),) = self.figures
        self.figures.clear()
        assert self.formats.pop(id(fig)) == ["png", "pdf"], "a figure is saved as a PNG with its PDF copy"
        fig.canvas.draw()  # the PDF was drawn last, at 72 dpi: lay the texts out as the PNG shows them
        return fig, area

    def legend_handles(self, leg: Legend) -> list[Any]:
        """The handles ``leg`` was made with (the artists drawn, or proxies standing for them)."""
        return next(h for lg, h in self.legends if lg is leg)


def _finite(xy: Any) -> bool:
    a = np.asarray(xy, dtype=float).reshape(-1, 2)
    return bool(np.isfinite(a).all(axis=1).any())


def _has_data(a: Any) -> bool:
    """Whether an artist of the axes shows something: a finite point, a path with vertices, a patch, an image."""
    if isinstance(a, Container):
        return any(_has_data(c) for c in a.get_children())
    if isinstance(a, Line2D):
        return _finite(a.get_xydata())
    if isinstance(a, Collection):
        if len(a.get_offsets()) and not np.allclose(a.get_offsets(), 0):
            return _finite(a.get_offsets())
        return any(_finite(p.vertices) for p in a.get_paths() if len(p.vertices))
    return a.get_visible()


def _rgb(c: Any) -> tuple[float, ...]:
    return tuple(round(v, 3) for v in to_rgba(c)[:3])


def _colours(a: Any) -> set[tuple[float, ...]]:
    if isinstance(a, Container):
        return set().union(*(_colours(c) for c in a.get_children()))
    if isinstance(a, Line2D):
        cs = [a.get_color(), a.get_markerfacecolor(), a.get_markeredgecolor()]
    elif isinstance(a, Collection):
        cs = [*a.get_facecolor(), *a.get_edgecolor()]
    elif isinstance(a, Patch):
        cs = [a.get_facecolor(), a.get_edgecolor()]
    else:
        cs = []
    return {_rgb(c) for c in cs if not isinstance(c, str) or c not in ("none", "auto")}


def _filled(a: Any) -> bool:
    faces = a.get_facecolor() if isinstance(a, (Patch, Collection)) else []
    return bool(len(faces)) and bool(np.asarray(to_rgba_array(faces))[:, 3].max() > 0)


def _stands_for(proxy: Any, a: Any) -> bool:
    """Whether a proxy handle stands for drawn artist ``a``: a coloured proxy, any artist drawn in its colour; a
    grey one (a kind of mark in any colour), an artist of its kind (line style and marker; filled or hollow)."""
    colour = proxy.get_color() if isinstance(proxy, Line2D) else proxy.get_facecolor()
    if isinstance(proxy, Patch) and not _filled(proxy):
        colour = proxy.get_edgecolor()
    r, g, b = _rgb(colour)
    if not r == g == b:
        return (r, g, b) in _colours(a)
    if isinstance(proxy, Patch):
        return isinstance(a, (Patch, Collection)) and _filled(a) == _filled(proxy)
    marker, style = proxy.get_marker(), proxy.get_linestyle()
    if style in ("None", "none", "", " "):  # marks only: a point set
        return isinstance(a, PathCollection) or (isinstance(a, Line2D) and a.get_marker() == marker)
    return isinstance(a, Line2D) and a.get_linestyle() == style and (marker in ("None", "") or a.get_marker() == marker)


def legend_problems(fig: Figure, saved: Saved) -> list[str]:
    """``label: why`` for each legend entry of ``fig`` that lists nothing drawn: an artist without data, or a proxy
    no drawn artist with data corresponds to."""
    drawn = [
        a
        for ax in fig.axes
        for a in (*ax.lines, *ax.collections, *ax.patches, *ax.images, *ax.containers)
        if _has_data(a)
    ]
    ours = {id(a) for ax in fig.axes for a in (*ax.get_children(), *ax.containers)}
    out = []
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None:
            continue
        for h, t in zip(saved.legend_handles(leg), leg.get_texts()):
            if id(h) in ours:
                out += [] if _has_data(h) else [f"{t.get_text()}: its {type(h).__name__} has no data"]
            elif not any(_stands_for(h, a) for a in drawn):
                out.append(f"{t.get_text()}: a proxy {type(h).__name__} that nothing drawn looks like")
    return out


#: Points of clear space every text keeps from every other (two texts closer read as one: "1379/1724371/726").
TEXT_GAP_PT = 2.0


def text_overlaps(fig: Figure) -> list[tuple[str, str]]:
    """Pairs of texts of ``fig`` (cells, ticks, labels, titles, legends) closer than ``TEXT_GAP_PT`` on the drawn
    figure (``get_window_extent`` of each text, grown by half the gap on every side)."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    half = TEXT_GAP_PT / 2 * fig.dpi / 72
    texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text()]
    boxes = [(t.get_text(), t.get_window_extent(r).padded(half)) for t in texts]
    return [(a, b) for (a, ba), (b, bb) in itertools.combinations(boxes, 2) if ba.overlaps(bb)]


def _texts(fig: Figure) -> list[Text]:
    out = [t for t in (fig._suptitle,) if t is not None and t.get_text()]  # noqa: SLF001
    for ax in fig.axes:
        out += [t for t in (ax.title, ax.xaxis.label, ax.yaxis.label) if t.get_text()]
        leg = ax.get_legend()
        if leg is not None:
            out += [t for t in leg.get_texts() if t.get_text()]
    return out


def _data_axes(fig: Figure) -> list[Axes]:
    """Axes that show data on scales (not colour bars, not pictures drawn without axes)."""
    return [ax for ax in fig.axes if ax.axison and ax.get_label() != "<colorbar>"]


def check_figure(name: str, fig: Figure, area: Bbox) -> None:
    """The checks every figure passes (see the module docstring); assertion messages name the figure."""
    w, h = fig.get_size_inches()
    assert w <= MAX_W and h <= MAX_H, (name, w, h)
    assert area.width <= MAX_W * fig.dpi + 1 and area.height <= MAX_H * fig.dpi + 1, (name, area)
    titles = [fig._suptitle] + [ax.title for ax in fig.axes]  # noqa: SLF001
    assert any(t is not None and t.get_text() for t in titles), f"{name}: no title"
    data = _data_axes(fig)
    for ax in data:
        assert ax.get_xlabel() and ax.get_ylabel(), f"{name}: an axes without labels ({ax.get_title()!r})"
    has_key = any(ax.get_legend() is not None for ax in fig.axes) or any(
        ax.get_label() == "<colorbar>" for ax in fig.axes
    )
    assert has_key or not data, f"{name}: neither a legend nor a colour bar"
    r = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    for t in _texts(fig):
        ext = t.get_window_extent(r)
        inside = area.x0 - 1 <= ext.x0 and ext.x1 <= area.x1 + 1 and area.y0 - 1 <= ext.y0 and ext.y1 <= area.y1 + 1
        assert inside, (name, t.get_text(), ext, area)
        assert t.get_fontsize() >= 6, (name, t.get_text(), t.get_fontsize())
    if name.startswith(MAPS):
        for ax in data:
            assert ax.get_aspect() == 1.0, (name, "not to scale")
            assert "(m)" in ax.get_xlabel() and "(m)" in ax.get_ylabel(), (name, ax.get_xlabel(), ax.get_ylabel())
