"""The world preview's top-down map: its legend lists each family drawn with its count, and it is written as a
PNG with a PDF beside it, the same bytes each time."""

from __future__ import annotations

from collections import Counter

from matplotlib.collections import PatchCollection

from roman_sim.core.figures import figure_files
from roman_sim.world import World
from roman_sim.world.preview import SAVE, topdown_figure


def test_the_topdown_legend_lists_each_family_drawn_with_its_count(tiny_world: World) -> None:
    fig = topdown_figure(tiny_world.truth, "tiny")
    (ax,) = fig.axes
    counts = Counter(o.family for o in tiny_world.truth.objects)
    assert len(counts) >= 2
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == [f"{f} ({n})" for f, n in sorted(counts.items())]
    drawn = {c.get_label(): len(c.get_paths()) for c in ax.collections if isinstance(c, PatchCollection)}
    assert drawn == {f"{f} ({n})": n for f, n in counts.items()}  # each entry is the family's footprints, drawn
    assert not [ln for ln in ax.lines if not len(ln.get_xydata())]  # no empty line stands in for a family


def test_the_topdown_map_is_a_png_and_a_pdf_with_the_same_bytes_each_time(tiny_world: World) -> None:
    first, again = (figure_files(topdown_figure(tiny_world.truth, "tiny"), **SAVE) for _ in range(2))
    assert first == again and first[".png"].startswith(b"\x89PNG") and first[".pdf"].startswith(b"%PDF")
