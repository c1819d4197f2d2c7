"""A run's plots rendered to PNG bytes, so that the stage that computes them writes nothing to the run folder.

The metric plots (``plots.write_metric_plots``), the example alignments
(``examples.draw_examples``) and the mask overlay (``maskview.plot_masks``) are drawing
functions that write their PNG files themselves. ``drawn_pngs`` runs such a function on a
temporary folder and keeps the bytes of the files it wrote; the report stage's ``save``
then writes those bytes into the run folder. The bytes are the ones the function would
have written in place (same data, same bytes), and the temporary folder is removed at once.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import AlignResult
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.types import EvaluationMetrics
from roman_sim.mapping.types import Submap


def drawn_pngs(draw: Callable[[Path], Iterable[Path]]) -> dict[str, bytes]:
    """File name -> bytes of every file ``draw(folder)`` wrote (and returned), in its order."""
    with tempfile.TemporaryDirectory(prefix="roman_sim_plots_") as tmp:
        return {p.name: p.read_bytes() for p in draw(Path(tmp))}


def metric_plot_pngs(metrics: EvaluationMetrics) -> tuple[dict[str, bytes], list[str]]:
    """The metric plots (file name -> PNG) and a note per plot not drawn."""
    from roman_sim.report.plots import write_metric_plots

    notes: list[str] = []

    def draw(folder: Path) -> list[Path]:
        written, skipped = write_metric_plots(metrics, folder)
        notes.extend(skipped)
        return written

    return drawn_pngs(draw), notes


def example_pngs(
    scores: list[PairScore], submaps: dict[str, Submap], results: dict[tuple[str, str, str], AlignResult]
) -> dict[str, bytes]:
    """``alignment_<method>.png`` per method (``examples.draw_examples``), file name -> PNG."""
    from roman_sim.report.examples import draw_examples

    return drawn_pngs(lambda folder: draw_examples(scores, submaps, results, folder))


def masks_png(
    rgb: NDArray[np.uint8], masks: Sequence[NDArray[np.bool_]], title: str, labels: Sequence[str | None]
) -> bytes:
    """The image with the masks over it (``maskview.plot_masks``) as PNG bytes."""
    from roman_sim.report.maskview import plot_masks

    return next(iter(drawn_pngs(lambda folder: [plot_masks(rgb, masks, folder / "masks.png", title, labels)]).values()))
