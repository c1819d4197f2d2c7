"""Evaluation plots (matplotlib, Agg canvas only; no pyplot global state).

Every metric plot is drawn from the JSON form of ``EvaluationMetrics`` (what
``metrics.json`` holds), except the alignment drawings, which need the submaps.
Undefined values (``None``) are left out of lines and drawn as "n/a" on bar charts.
PNGs are written atomically and without timestamps, so the same data gives the same bytes.
"""

from __future__ import annotations

import io
import logging
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from roman_sim.align.base import AlignResult
from roman_sim.core.atomic import write_bytes
from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.types import EvaluationMetrics
from roman_sim.geometry import transform_points
from roman_sim.mapping.types import Submap

log = logging.getLogger(__name__)


def _figure(w: float = 6.0, h: float = 4.0) -> tuple[Figure, Axes]:
    fig = Figure(figsize=(w, h), dpi=100)
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot(1, 1, 1)


def save_png(fig: Figure, path: str | Path) -> Path:
    """Render ``fig`` to PNG in memory and write it atomically."""
    path = Path(path)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", metadata={"Software": None})
    write_bytes(path, buf.getvalue())
    log.debug("wrote %s", path)
    return path


def _nan(values: list[Any]) -> np.ndarray:
    return np.array([np.nan if v is None else float(v) for v in values], dtype=np.float64)


def _methods(metrics: dict[str, Any]) -> dict[str, Any]:
    methods = metrics.get("methods")
    if not isinstance(methods, dict):
        raise EvaluationError("metrics have no 'methods' table (not a metrics.summary output)")
    return methods


def plot_pr(metrics: dict[str, Any], path: str | Path) -> Path:
    """Precision against recall over the association threshold k, one line per method."""
    fig, ax = _figure()
    for name, m in _methods(metrics).items():
        c = m["pr_curve"]
        ax.plot(_nan(c["recall"]), _nan(c["precision"]), marker=".", label=name)
    ax.set(xlabel="recall", ylabel="precision", xlim=(0, 1.02), ylim=(0, 1.05),
           title="Precision-recall over association count k")
    if not metrics.get("n_relevant"):
        ax.text(0.5, 0.5, "no relevant pairs: recall undefined", ha="center", transform=ax.transAxes)
    ax.grid(alpha=0.3)
    if _methods(metrics):
        ax.legend(loc="best", fontsize=8)
    return save_png(fig, path)


def _grouped_bars(ax: Axes, methods: dict[str, Any], table: str, key: str = "max_recall") -> None:
    names = list(methods)
    labels = [b["label"] for b in methods[names[0]][table]] if names else []
    width = 0.8 / max(len(names), 1)
    x = np.arange(len(labels))
    for i, name in enumerate(names):
        vals = _nan([b[key] for b in methods[name][table]])
        pos = x - 0.4 + width * (i + 0.5)
        ax.bar(pos, np.nan_to_num(vals), width, label=name)
        for p, v in zip(pos, vals):
            if np.isnan(v):
                ax.text(p, 0.02, "n/a", ha="center", va="bottom", fontsize=7, rotation=90)
    ax.set_xticks(x, labels)
    ax.set_ylim(0, 1.05)
    ax.grid(axis="y", alpha=0.3)
    if names:
        ax.legend(fontsize=8)


def plot_heading_recall(metrics: dict[str, Any], path: str | Path, fine: bool = False) -> Path:
    """Max recall per heading-difference bin, grouped bars per method (coarse or fine bins)."""
    fig, ax = _figure(7.0 if fine else 6.0, 4.0)
    _grouped_bars(ax, _methods(metrics), "heading_bins_fine" if fine else "heading_bins")
    ax.set(xlabel="heading difference (deg)", ylabel="max recall",
           title="Recall per heading difference" + (" (fine bins)" if fine else ""))
    return save_png(fig, path)


def plot_ambiguity_recall(metrics: dict[str, Any], path: str | Path) -> Path:
    """Max recall per ground-truth ambiguity bin, one line per method."""
    fig, ax = _figure()
    for name, m in _methods(metrics).items():
        bins = m["ambiguity_bins"]
        mid = [(b["lo"] + b["hi"]) / 2 for b in bins]
        ax.plot(mid, _nan([b["max_recall"] for b in bins]), marker="o", label=name)
    ax.set(xlabel="place ambiguity", ylabel="max recall", ylim=(0, 1.05), title="Recall against ambiguity")
    unknown = max((m.get("n_ambiguity_unknown", 0) for m in _methods(metrics).values()), default=0)
    if unknown:
        ax.text(0.02, 0.02, f"{unknown} pairs without ambiguity value", transform=ax.transAxes, fontsize=8)
    ax.grid(alpha=0.3)
    if _methods(metrics):
        ax.legend(fontsize=8)
    return save_png(fig, path)


def _cloud(s: Submap) -> np.ndarray:
    if s.points:
        return np.concatenate([np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in s.points])
    return np.asarray(s.centers, dtype=np.float64).reshape(-1, 3)


def _assoc_colours(a: Submap, b: Submap, assoc: np.ndarray) -> list[str]:
    if a.truth is None or b.truth is None:
        return ["tab:gray"] * len(assoc)
    ia, ib = a.truth.object_ids[assoc[:, 0]], b.truth.object_ids[assoc[:, 1]]
    return ["tab:green" if x == y and x >= 0 else "tab:red" for x, y in zip(ia, ib)]


def plot_alignment(
    a: Submap, b: Submap, result: AlignResult, path: str | Path,
    T_a_b_true: np.ndarray | None = None, title: str | None = None,
) -> Path:
    """Top-down view of submap a and submap b moved by the estimate, with association lines.

    Lines are green when both segments come from the same true object, red otherwise
    (grey without truth); none for a method whose associations are not segments (visual).
    With ``T_a_b_true``, b's true placement is drawn faintly.
    """
    if result.T_a_b is None:
        raise EvaluationError(f"{result.method} on {a.name}|{b.name}: no estimate to draw ({result.reason})")
    assoc = np.asarray(result.associations, dtype=np.int64).reshape(-1, 2)
    if result.info.get("association_kind") == "keyframe_features":  # feature pairs, not segments: no lines
        assoc = assoc[:0]
    if len(assoc) and (assoc[:, 0].max() >= len(a) or assoc[:, 1].max() >= len(b)):
        raise EvaluationError(f"{result.method}: association index outside the submaps")
    fig, ax = _figure(6.0, 6.0)
    if T_a_b_true is not None:
        t = transform_points(T_a_b_true, _cloud(b))
        ax.scatter(t[:, 0], t[:, 1], s=4, c="0.8", label=f"{b.name} (true)")
    pa, pb = _cloud(a), transform_points(result.T_a_b, _cloud(b))
    ax.scatter(pa[:, 0], pa[:, 1], s=5, c="tab:blue", label=a.name)
    ax.scatter(pb[:, 0], pb[:, 1], s=5, c="tab:orange", label=f"{b.name} (estimate)")
    ca, cb = a.centers[assoc[:, 0]], transform_points(result.T_a_b, b.centers[assoc[:, 1]])
    for p, q, col in zip(ca, cb, _assoc_colours(a, b, assoc)):
        ax.plot([p[0], q[0]], [p[1], q[1]], color=col, lw=0.8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel=f"x in {a.name} (m)", ylabel="y (m)",
           title=title or f"{result.method}: {a.name} | {b.name}, {len(assoc)} associations")
    ax.legend(fontsize=8, loc="upper right")
    return save_png(fig, path)


def write_metric_plots(evaluation: EvaluationMetrics, plots_dir: str | Path) -> list[Path]:
    """The standard metric plots into ``plots_dir``; returns their paths."""
    d = Path(plots_dir)
    metrics = evaluation.to_json()
    return [
        plot_pr(metrics, d / "precision_recall.png"),
        plot_heading_recall(metrics, d / "recall_heading.png"),
        plot_heading_recall(metrics, d / "recall_heading_fine.png", fine=True),
        plot_ambiguity_recall(metrics, d / "recall_ambiguity.png"),
    ]


def pick_examples(scores: list[PairScore]) -> tuple[PairScore | None, PairScore | None]:
    """(most-supported correct relevant pair, most-supported wrong estimate), None if absent."""
    good = [s for s in scores if s.correct and s.truth.relevant]
    bad = [s for s in scores if not s.correct and np.isfinite(s.rot_err_deg)]
    pick = lambda xs: max(xs, key=lambda s: s.n_assoc) if xs else None  # noqa: E731  first on ties
    return pick(good), pick(bad)


def draw_examples(
    scores: list[PairScore],
    submaps: dict[str, Submap],
    results: dict[tuple[str, str, str], AlignResult],
    plots_dir: str | Path,
) -> list[Path]:
    """Draw one correct and one wrong alignment (those that exist) into ``plots_dir``.

    Args:
        scores: scored pairs (any methods).
        submaps: submaps by name (``robot/index``).
        results: aligner results keyed by ``(a name, b name, method)``.
    """
    out = []
    for tag, s in zip(("correct", "wrong"), pick_examples(scores)):
        if s is None:
            continue
        key = (s.truth.a, s.truth.b, s.method)
        if key not in results or s.truth.a not in submaps or s.truth.b not in submaps:
            raise EvaluationError(f"no submaps/result for example pair {s.truth.a}|{s.truth.b} ({s.method})")
        title = (f"{tag}: {s.method} {s.truth.a} | {s.truth.b}, {s.n_assoc} assoc, "
                 f"err {s.rot_err_deg:.1f} deg / {s.trans_err_m:.2f} m")
        out.append(plot_alignment(submaps[s.truth.a], submaps[s.truth.b], results[key],
                                  Path(plots_dir) / f"alignment_{tag}.png", s.truth.T_a_b_true, title))
    return out
