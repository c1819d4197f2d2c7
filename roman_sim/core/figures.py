"""Figure files: every figure the package saves, as a PNG with a vector PDF beside it.

``save_figure`` is the one place a matplotlib figure becomes files. It writes the PNG at the
path it is given and the same figure as a PDF beside it (``x.png`` and ``x.pdf``), both
atomically (``roman_sim.core.atomic``); ``figure_files`` gives the same bytes in memory.

- **Same data, same bytes.** Neither file carries a date or the library's version (PNG
  ``Software``, PDF ``CreationDate`` and ``Producer`` are left out), so a figure drawn
  again from the same data gives the same bytes (with the same matplotlib and fonts).
- **PDF rather than SVG** as the vector format: LaTeX includes it as it is (a paper is
  where a vector figure goes), its fonts are embedded (TrueType, ``pdf.fonttype`` 42, the
  kind publishers accept) so it looks the same on every machine while its text stays
  text, and the images inside it are compressed binary streams, where SVG holds them as
  base64 text a third larger. The PNG stays the file the reports and pages show.
- **Dense artists are images inside the PDF** (``rasterize_dense``): images, and point
  clouds or circle sets with more than ``DENSE_ELEMENTS`` elements, at ``RASTER_DPI``; the
  axes, text and lines stay vectors. A map view's thousands of points would otherwise be
  thousands of vector paths (several MB, slow to open). The PNG is unaffected.
- **Data with the figure.** ``data`` (JSON-ready) is stored in a PNG text chunk
  (``DATA_KEY`` unless another key is named); ``read_png_data`` reads it back, so a test can
  compare what a figure shows with its source without comparing pixels.

``drawn_legend`` builds a legend only from labelled artists that hold data (``has_data``),
so a legend never lists a line or a point set that is not drawn.
"""

from __future__ import annotations

import io
import json
import logging
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from roman_sim.core.atomic import write_bytes
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import parse_json

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.legend import Legend

log = logging.getLogger(__name__)

#: Suffix of the raster copy (the file a path names) and of the vector copy beside it.
PNG, VECTOR = ".png", ".pdf"
#: Resolution (dots per inch) of the artists drawn as images inside the vector copy.
RASTER_DPI = 200
#: A collection with more elements than this (points of a scatter, circles) is an image inside the PDF.
DENSE_ELEMENTS = 500
#: Metadata per format: nothing that changes from one drawing to the next.
METADATA: dict[str, dict[str, str | None]] = {
    PNG: {"Software": None},
    VECTOR: {"Creator": "roman_sim", "Producer": None, "CreationDate": None},
}
#: PNG text chunk that holds the data a figure was drawn from (``save_figure(..., data=...)``).
DATA_KEY = "roman_sim_data"

#: A figure's files in memory: suffix (``PNG``, ``VECTOR``) -> bytes.
FigureFiles = dict[str, bytes]


def vector_path(path: str | Path) -> Path:
    """Where the vector copy of the figure at ``path`` goes: the same name with ``VECTOR``'s suffix."""
    return Path(path).with_suffix(VECTOR)


def _elements(coll: Any) -> int:
    """How many things a collection draws: its offsets (scatter points, circles) or else its paths."""
    offsets = np.asarray(coll.get_offsets())
    return max(len(offsets) if offsets.ndim == 2 else 0, len(coll.get_paths()))


def rasterize_dense(fig: Figure) -> int:
    """Mark ``fig``'s images and collections of more than ``DENSE_ELEMENTS`` elements to be drawn as images in
    vector files; returns how many were marked (raster output is unchanged)."""
    from matplotlib.collections import Collection
    from matplotlib.image import AxesImage

    n = 0
    for ax in fig.axes:
        for a in ax.get_children():
            if isinstance(a, AxesImage) or (isinstance(a, Collection) and _elements(a) > DENSE_ELEMENTS):
                a.set_rasterized(True)
                n += 1
    return n


def _render(fig: Figure, suffix: str, metadata: Mapping[str, str | None], bbox_inches: str | None) -> bytes:
    from matplotlib import rc_context

    buf = io.BytesIO()
    dpi: float | str = RASTER_DPI if suffix == VECTOR else "figure"
    with rc_context({"pdf.fonttype": 42}):
        fig.savefig(buf, format=suffix[1:], metadata=dict(metadata), bbox_inches=bbox_inches, dpi=dpi)
    return buf.getvalue()


def figure_files(
    fig: Figure,
    data: object = None,
    data_key: str = DATA_KEY,
    tight_layout: bool = True,
    bbox_inches: str | None = None,
    vector: bool = True,
) -> FigureFiles:
    """``fig`` as PNG bytes and (``vector``) PDF bytes, laid out once for both.

    Args:
        fig: the figure (any canvas; the files are rendered by matplotlib's own backends).
        data: JSON-ready data stored in the PNG's ``data_key`` text chunk (``read_png_data``).
        data_key: the text chunk's key.
        tight_layout: lay the figure out with ``Figure.tight_layout`` first.
        bbox_inches: ``"tight"`` crops both files to what is drawn.
        vector: also render the PDF.
    """
    if tight_layout:
        fig.tight_layout()
    rasterize_dense(fig)
    meta = dict(METADATA[PNG])
    if data is not None:
        meta[data_key] = json.dumps(data, sort_keys=True)
    out = {PNG: _render(fig, PNG, meta, bbox_inches)}
    if vector:
        out[VECTOR] = _render(fig, VECTOR, METADATA[VECTOR], bbox_inches)
    return out


def save_figure(
    fig: Figure,
    path: str | Path,
    data: object = None,
    data_key: str = DATA_KEY,
    tight_layout: bool = True,
    bbox_inches: str | None = None,
) -> Path:
    """Write ``fig`` atomically as a PNG at ``path`` and as a PDF beside it (``vector_path``); returns ``path``.

    A ``path`` that ends in ``.pdf`` gets the PDF alone. The other arguments are ``figure_files``'.
    """
    path = Path(path)
    only_vector = path.suffix.lower() == VECTOR
    files = figure_files(fig, data, data_key, tight_layout, bbox_inches)
    for suffix, blob in files.items():
        if suffix == VECTOR or not only_vector:
            write_bytes(path if suffix == PNG else vector_path(path), blob)
    log.debug("wrote %s and its vector copy", path)
    return path


def read_figure_files(path: str | Path) -> FigureFiles:
    """The files ``save_figure`` wrote for ``path`` (the PNG, and its vector copy when there is one)."""
    path = Path(path)
    out = {PNG: path.read_bytes()}
    if vector_path(path).is_file():
        out[VECTOR] = vector_path(path).read_bytes()
    return out


def remove_figure(path: str | Path) -> None:
    """Remove a figure's PNG at ``path`` and its vector copy (those that exist)."""
    Path(path).unlink(missing_ok=True)
    vector_path(path).unlink(missing_ok=True)


def read_png_data(path: str | Path, data_key: str = DATA_KEY) -> JSON:
    """The data ``save_figure`` stored with a figure's PNG (None when it stored none; RecordError
    naming the file when the chunk is not JSON)."""
    from PIL import Image

    with Image.open(path) as im:
        text = im.info.get(data_key)
    return None if text is None else parse_json(text, f"{path}: text chunk {data_key}")


def _finite(xy: Any) -> bool:
    """Whether the (N, 2) points ``xy`` hold a finite one."""
    return bool(np.isfinite(np.asarray(xy, dtype=float).reshape(-1, 2)).all(axis=1).any())


def has_data(artist: Artist) -> bool:
    """Whether ``artist`` draws something: a line or point set with a finite point, a bar, a patch, an image.

    A container (error bars, bars) has data when one of its parts has.
    """
    from matplotlib.collections import Collection, EllipseCollection, PathCollection, RegularPolyCollection
    from matplotlib.container import Container
    from matplotlib.image import AxesImage
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if isinstance(artist, Container):
        return any(has_data(a) for a in artist.get_children())
    if isinstance(artist, Line2D):
        return _finite(artist.get_xydata())
    if isinstance(artist, (PathCollection, EllipseCollection, RegularPolyCollection)):
        return _finite(artist.get_offsets())
    if isinstance(artist, Collection):
        return any(_finite(p.vertices) for p in artist.get_paths())
    if isinstance(artist, Patch):
        return _finite(artist.get_patch_transform().transform(np.asarray(artist.get_path().vertices)))
    if isinstance(artist, AxesImage):
        return bool(np.asarray(artist.get_array()).size)
    return True


def drawn_legend(ax: Axes, axes: Iterable[Axes] | None = None, **kwargs: Any) -> Legend | None:
    """A legend on ``ax`` of the labelled artists of ``axes`` (default: ``ax``) that hold data, one entry per
    label (its first artist with data), or no legend when none does. ``kwargs`` go to ``Axes.legend``."""
    handles: list[Any] = []
    labels: list[str] = []
    for a in axes if axes is not None else [ax]:
        for h, label in zip(*a.get_legend_handles_labels()):
            if label not in labels and has_data(h):
                handles.append(h)
                labels.append(label)
    return ax.legend(handles, labels, **kwargs) if handles else None
