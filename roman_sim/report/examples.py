"""Example alignments per method: one correct pair and the worst false positive.

One figure per method (``alignment_<method>.png``): a row for the correct pair and a row for
the worst false positive. Each row shows both submaps from above twice: on the left b placed
by the method's estimate, on the right b placed by the truth. The method's selected associations join the
two segment centres, green when both segments come from the same true object and red when
not (grey without truth), so a drawing separates "found the right objects" from "estimated
the transform well".

The correct pair is the correct relevant pair with the most associations. A false positive
is a wrong estimate the pose graph would accept: at least ``ExampleRule.min_assoc``
associations (the acceptance threshold). The worst is the one furthest off, its error in
units of the success tolerances: max(rotation error / rotation tolerance, translation error /
translation tolerance); ties: more associations, then pair order. A method without such a
false positive gets the correct row only, and its title says so.
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.lines import Line2D

from roman_sim.align.base import AlignResult, segment_associations
from roman_sim.core.errors import EvaluationError
from roman_sim.core.figures import has_data, save_figure
from roman_sim.core.geometry import transform_points
from roman_sim.evaluation.metrics import PairScore
from roman_sim.mapping.types import Submap
from roman_sim.report.plots import figure

log = logging.getLogger(__name__)

#: Points drawn per segment at most (a deterministic stride keeps drawings fast).
POINTS_PER_SEGMENT = 60


def _cloud(s: Submap) -> np.ndarray:
    if s.points:
        pts = [np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in s.points]
        return np.concatenate([p[:: max(1, -(-len(p) // POINTS_PER_SEGMENT))] for p in pts])
    return np.asarray(s.centers, dtype=np.float64).reshape(-1, 3)


#: Association line colour -> what it means (``assoc_colours``).
ASSOC_LABELS = {
    "tab:green": "association, same true object",
    "tab:red": "association, different objects",
    "tab:gray": "association (no truth)",
}


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
    ax.scatter(pa[:, 0], pa[:, 1], s=3, c="tab:blue", label=f"submap a: {a.name}")
    ax.scatter(pb[:, 0], pb[:, 1], s=3, c="tab:orange", label=f"submap b: {b.name}")
    ca, cb = a.centers[assoc[:, 0]], transform_points(T_a_b, b.centers[assoc[:, 1]])
    for p, q, col in zip(ca, cb, colours):
        ax.plot([p[0], q[0]], [p[1], q[1]], color=col, lw=1.0)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel=f"x in {a.name} (m)", ylabel=f"y in {a.name} (m)")
    ax.set_title(title, fontsize=9)
    handles = [h for h in ax.get_legend_handles_labels()[0] if has_data(h)]  # a submap without points: not listed
    handles += [Line2D([], [], color=c, lw=1.0, label=ASSOC_LABELS[c]) for c in ASSOC_LABELS if c in colours]
    ax.legend(handles=handles, fontsize=7, loc="upper right")


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
    return save_figure(fig, path)


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


@dataclass(frozen=True)
class ExampleRule:
    """What makes a false positive and how wrong it is.

    Attributes:
        min_assoc: associations an estimate needs to count as accepted (the pose graph's
            acceptance threshold; at least 1).
        rot_tol_deg, trans_tol_m: the success tolerances an error is measured in.
    """

    min_assoc: int = 1
    rot_tol_deg: float = 5.0
    trans_tol_m: float = 1.0

    def error(self, s: PairScore) -> float:
        """How wrong ``s``'s estimate is, in tolerances: the larger of its two errors over their tolerance."""
        return max(s.rot_err_deg / self.rot_tol_deg, s.trans_err_m / self.trans_tol_m)

    def false_positives(self, scores: list[PairScore]) -> list[PairScore]:
        """The wrong estimates with at least ``min_assoc`` associations, worst first."""
        k = max(1, self.min_assoc)
        bad = [s for s in scores if not s.correct and np.isfinite(s.rot_err_deg) and s.n_assoc >= k]
        return sorted(bad, key=lambda s: (-self.error(s), -s.n_assoc))


def pick_examples(
    scores: list[PairScore], rule: ExampleRule | None = None
) -> tuple[PairScore | None, PairScore | None]:
    """(most-supported correct relevant pair, worst false positive under ``rule``) of one method; None if absent."""
    good = [s for s in scores if s.correct and s.truth.relevant]
    best = max(good, key=lambda s: s.n_assoc) if good else None
    bad = (rule or ExampleRule()).false_positives(scores)
    return best, (bad[0] if bad else None)


def _slug(method: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", method)


def _caption(tag: str, s: PairScore) -> str:
    t = s.truth
    return (
        f"{tag}: {t.a} | {t.b}, {t.kind}, {t.center_dist_m:.1f} m, {t.heading_diff_deg:.0f} deg\n"
        f"error {s.rot_err_deg:.1f} deg / {s.trans_err_m:.2f} m, {t.true_correspondences} true correspondences"
    )


def example_title(method: str, rule: ExampleRule, n_false: int, has_correct: bool) -> str:
    """The figure's title: what its rows are, and which of them the method has none of."""
    k = max(1, rule.min_assoc)
    head = f"{method}: a correct alignment and the worst false positive"
    rank = (
        f"worst: the largest error in tolerances ({rule.rot_tol_deg:g} deg, {rule.trans_tol_m:g} m) "
        f"among the {n_false} wrong estimates with >= {k} associations"
    )
    if not n_false:
        rank = f"no wrong estimate has >= {k} associations"
    return f"{head}\n{rank}" + ("" if has_correct else "; no correct relevant pair")


def example_rows(
    scores: list[PairScore],
    submaps: dict[str, Submap],
    results: dict[tuple[str, str, str], AlignResult],
    rule: ExampleRule | None = None,
) -> dict[str, tuple[str, list[Example]]]:
    """Per method (sorted): its figure's title and rows, its correct example and its worst false positive
    (those that exist; methods with neither are left out).

    Args:
        scores: scored pairs (any methods).
        submaps: submaps by name (``robot/index``), with truth.
        results: aligner results keyed by ``(a name, b name, method)``.
        rule: what counts as a false positive and how its error is measured (default
            ``ExampleRule()``: any wrong estimate, 5 deg / 1 m).

    Raises:
        EvaluationError: an example pair without its submaps or its result.
    """
    rule = rule or ExampleRule()
    out: dict[str, tuple[str, list[Example]]] = {}
    for method in sorted({s.method for s in scores}):
        rows: list[Example] = []
        mine = [s for s in scores if s.method == method]
        n_false = len(rule.false_positives(mine))
        best, worst = pick_examples(mine, rule)
        fp_tag = "" if worst is None else f"worst false positive, {rule.error(worst):.1f} x the tolerance"
        for tag, s in (("correct", best), (fp_tag, worst)):
            if s is None:
                continue
            key = (s.truth.a, s.truth.b, s.method)
            if key not in results or s.truth.a not in submaps or s.truth.b not in submaps:
                raise EvaluationError(f"no submaps/result for example pair {s.truth.a}|{s.truth.b} ({s.method})")
            rows.append((submaps[s.truth.a], submaps[s.truth.b], results[key], s.truth.T_a_b_true, _caption(tag, s)))
        if rows:
            out[method] = (example_title(method, rule, n_false, best is not None), rows)
    return out


def example_file(method: str) -> str:
    """The file name of ``method``'s example figure."""
    return f"alignment_{_slug(method)}.png"


def plot_method_examples(method: str, rows: list[Example], plots_dir: str | Path, title: str = "") -> Path:
    """``alignment_<method>.png`` in ``plots_dir`` from ``method``'s rows and title (``example_rows``)."""
    title = title or f"{method}: a correct alignment and the worst false positive"
    return plot_examples(rows, Path(plots_dir) / example_file(method), title)


def draw_examples(
    scores: list[PairScore],
    submaps: dict[str, Submap],
    results: dict[tuple[str, str, str], AlignResult],
    plots_dir: str | Path,
    rule: ExampleRule | None = None,
) -> list[Path]:
    """``alignment_<method>.png`` per method: its correct example and its worst false positive (those that exist).

    Args:
        scores: scored pairs (any methods).
        submaps: submaps by name (``robot/index``), with truth.
        results: aligner results keyed by ``(a name, b name, method)``.
        rule: what counts as a false positive (``example_rows``).
    """
    return [
        plot_method_examples(m, rows, plots_dir, title)
        for m, (title, rows) in example_rows(scores, submaps, results, rule).items()
    ]
