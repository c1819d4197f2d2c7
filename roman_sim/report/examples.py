"""Example alignments per method: one correct pair and the worst false positive.

One figure per method (``alignment_<method>.png``): a row for the correct pair and a row for
the worst false positive. Each row shows both submaps from above twice: on the left b placed
by the method's estimate, on the right b placed by the truth. The method's selected associations join the
two segment centres, green when both segments come from the same true object and red when
not (grey without truth), so a drawing separates "found the right objects" from "estimated
the transform well". The worst false positive is the wrong estimate with the most
associations (the one that survives the highest acceptance threshold).
"""

from __future__ import annotations

import logging
import re
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes

from roman_sim.align.base import AlignResult, segment_associations
from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import transform_points
from roman_sim.evaluation.metrics import PairScore
from roman_sim.mapping.types import Submap
from roman_sim.report.plots import figure, save_png

log = logging.getLogger(__name__)

#: Points drawn per segment at most (a deterministic stride keeps drawings fast).
POINTS_PER_SEGMENT = 60


def _cloud(s: Submap) -> np.ndarray:
    if s.points:
        pts = [np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in s.points]
        return np.concatenate([p[:: max(1, -(-len(p) // POINTS_PER_SEGMENT))] for p in pts])
    return np.asarray(s.centers, dtype=np.float64).reshape(-1, 3)


def assoc_colours(a: Submap, b: Submap, assoc: np.ndarray) -> list[str]:
    """Green for associations of the same true object, red otherwise, grey without truth."""
    if a.truth is None or b.truth is None:
        return ["tab:gray"] * len(assoc)
    ia, ib = a.truth.object_ids[assoc[:, 0]], b.truth.object_ids[assoc[:, 1]]
    return ["tab:green" if x == y and x >= 0 else "tab:red" for x, y in zip(ia, ib)]


def _panel(
    ax: Axes, a: Submap, b: Submap, T_a_b: np.ndarray, assoc: np.ndarray, colours: list[str], title: str
) -> None:
    pa, pb = _cloud(a), transform_points(T_a_b, _cloud(b))
    ax.scatter(pa[:, 0], pa[:, 1], s=3, c="tab:blue", label=a.name)
    ax.scatter(pb[:, 0], pb[:, 1], s=3, c="tab:orange", label=b.name)
    ca, cb = a.centers[assoc[:, 0]], transform_points(T_a_b, b.centers[assoc[:, 1]])
    for p, q, col in zip(ca, cb, colours):
        ax.plot([p[0], q[0]], [p[1], q[1]], color=col, lw=1.0)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel=f"x in {a.name} (m)", ylabel="y (m)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper right")


def _check(a: Submap, b: Submap, result: AlignResult) -> np.ndarray:
    if result.T_a_b is None:
        raise EvaluationError(f"{result.method} on {a.name}|{b.name}: no estimate to draw ({result.reason})")
    assoc = np.asarray(result.associations, dtype=np.int64).reshape(-1, 2)
    if not segment_associations(result):  # feature matches, not segments: no association lines
        return assoc[:0]
    if len(assoc) and (assoc.min() < 0 or assoc[:, 0].max() >= len(a) or assoc[:, 1].max() >= len(b)):
        raise EvaluationError(f"{result.method}: association index outside the submaps")
    return assoc


def _row(
    axes: list[Axes], a: Submap, b: Submap, result: AlignResult, T_a_b_true: np.ndarray | None, title: str
) -> None:
    assoc = _check(a, b, result)
    T_est = result.T_a_b
    assert T_est is not None  # _check rejects a result without an estimate
    colours = assoc_colours(a, b, assoc)
    n_true = colours.count("tab:green")
    counts = f"{len(assoc)} associations: {n_true} same object (green), {len(assoc) - n_true} not (red)"
    _panel(axes[0], a, b, T_est, assoc, colours, f"{title}\nb placed by the estimate")
    if T_a_b_true is not None:
        _panel(axes[1], a, b, T_a_b_true, assoc, colours, f"b placed by the truth\n{counts}")


#: ``(a, b, result, T_a_b_true or None, title)``
Example = tuple[Submap, Submap, AlignResult, np.ndarray | None, str]


def plot_examples(rows: list[Example], path: str | Path, suptitle: str = "") -> Path:
    """One row per example ``(a, b, result, T_a_b_true, title)``: estimate on the left, truth on the right.

    Raises:
        EvaluationError: an example without an estimate, or an association index outside the submaps.
    """
    for a, b, res, _, _ in rows:
        _check(a, b, res)
    fig = figure(11.0, 5.2 * len(rows), ncols=2, nrows=len(rows))
    for i, (a, b, res, T_true, title) in enumerate(rows):
        _row(fig.axes[2 * i : 2 * i + 2], a, b, res, T_true, title)
        if T_true is None:
            fig.axes[2 * i + 1].set_axis_off()
    if suptitle:
        fig.suptitle(suptitle, fontsize=10)
    return save_png(fig, path)


def plot_alignment(
    a: Submap,
    b: Submap,
    result: AlignResult,
    path: str | Path,
    T_a_b_true: np.ndarray | None = None,
    title: str | None = None,
) -> Path:
    """One pair: b placed by the estimate (left) and by the truth (right, when given)."""
    return plot_examples([(a, b, result, T_a_b_true, title or f"{result.method}: {a.name} | {b.name}")], path)


def pick_examples(scores: list[PairScore]) -> tuple[PairScore | None, PairScore | None]:
    """(most-supported correct relevant pair, worst false positive) of one method; None if absent.

    The worst false positive is the wrong estimate with the most associations (ties: the
    larger translation error, then pair order).
    """
    good = [s for s in scores if s.correct and s.truth.relevant]
    bad = [s for s in scores if not s.correct and np.isfinite(s.rot_err_deg) and s.n_assoc > 0]
    best = max(good, key=lambda s: s.n_assoc) if good else None
    worst = max(bad, key=lambda s: (s.n_assoc, s.trans_err_m)) if bad else None
    return best, worst


def _slug(method: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", method)


def _caption(tag: str, s: PairScore) -> str:
    t = s.truth
    return (
        f"{tag}: {t.a} | {t.b}, {t.kind}, {t.center_dist_m:.1f} m, {t.heading_diff_deg:.0f} deg\n"
        f"error {s.rot_err_deg:.1f} deg / {s.trans_err_m:.2f} m, {t.true_correspondences} true correspondences"
    )


def example_rows(
    scores: list[PairScore],
    submaps: dict[str, Submap],
    results: dict[tuple[str, str, str], AlignResult],
) -> dict[str, list[Example]]:
    """Per method (sorted): the rows of its figure, its correct example and its worst false positive
    (those that exist; methods with neither are left out).

    Args:
        scores: scored pairs (any methods).
        submaps: submaps by name (``robot/index``), with truth.
        results: aligner results keyed by ``(a name, b name, method)``.

    Raises:
        EvaluationError: an example pair without its submaps or its result.
    """
    out: dict[str, list[Example]] = {}
    for method in sorted({s.method for s in scores}):
        rows: list[Example] = []
        mine = [s for s in scores if s.method == method]
        for tag, s in zip(("correct", "worst false positive"), pick_examples(mine)):
            if s is None:
                continue
            key = (s.truth.a, s.truth.b, s.method)
            if key not in results or s.truth.a not in submaps or s.truth.b not in submaps:
                raise EvaluationError(f"no submaps/result for example pair {s.truth.a}|{s.truth.b} ({s.method})")
            rows.append((submaps[s.truth.a], submaps[s.truth.b], results[key], s.truth.T_a_b_true, _caption(tag, s)))
        if rows:
            out[method] = rows
    return out


def example_file(method: str) -> str:
    """The file name of ``method``'s example figure."""
    return f"alignment_{_slug(method)}.png"


def plot_method_examples(method: str, rows: list[Example], plots_dir: str | Path) -> Path:
    """``alignment_<method>.png`` in ``plots_dir`` from ``method``'s rows (``example_rows``)."""
    return plot_examples(
        rows, Path(plots_dir) / example_file(method), f"{method}: a correct alignment and the worst false positive"
    )


def draw_examples(
    scores: list[PairScore],
    submaps: dict[str, Submap],
    results: dict[tuple[str, str, str], AlignResult],
    plots_dir: str | Path,
) -> list[Path]:
    """``alignment_<method>.png`` per method: its correct example and its worst false positive (those that exist).

    Args:
        scores: scored pairs (any methods).
        submaps: submaps by name (``robot/index``), with truth.
        results: aligner results keyed by ``(a name, b name, method)``.
    """
    return [plot_method_examples(m, rows, plots_dir) for m, rows in example_rows(scores, submaps, results).items()]
