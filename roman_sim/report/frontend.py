"""The front end's grades for people: the report's markdown section and a three-panel figure."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from roman_sim.evaluation.frontend_types import FrontEndGrades
from roman_sim.report.plots import save_png


def _f(v: float | None, digits: int = 2) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def frontend_report_lines(grades: FrontEndGrades) -> list[str]:
    """The report's front-end section (markdown lines): segmentation grades, misses, cosines."""
    s = grades.segmentation
    lines = [
        "## Front end against truth",
        "",
        f"Segmenter `{grades.segmenter}`, encoder `{grades.encoder or 'none'}`, graded on {s.frames} frames "
        "against the instance image (objects in ROMAN's mask area window, after its erosion).",
        "",
        "| precision | recall | mean IoU | masks / frame | over-segmented | under-segmented | spurious |",
        "|---|---|---|---|---|---|---|",
        f"| {_f(s.precision)} | {_f(s.recall)} | {_f(s.mean_iou)} | {_f(s.masks / max(s.frames, 1), 1)} | "
        f"{s.over_segmented} | {s.under_segmented} | {s.spurious} |",
        "",
    ]
    rows = s.by_distance()
    if rows:
        lines += ["| object distance (m) | object views | missed | recall (IoU match) |", "|---|---|---|---|"]
        for r in rows:
            to = "" if r["to_m"] is None else f"{r['to_m']:g}"
            rec = None if not r["objects"] else 1.0 - r["unmatched"] / r["objects"]
            lines.append(f"| {r['from_m']:g}-{to} | {r['objects']} | {r['missed']} | {_f(rec)} |")
        lines.append("")
    d = grades.descriptors
    if d is not None:
        lines += ["| descriptor pairs | pairs | mean cosine | 5 % | 95 % |", "|---|---|---|---|---|"]
        for name, st in d.classes.items():
            lines.append(f"| {name.replace('_', ' ')} | {st.pairs} | {_f(st.mean)} | {_f(st.p05)} | {_f(st.p95)} |")
        lines.append("")
    return lines


def plot_frontend_grades(grades: FrontEndGrades, path: str | Path) -> Path:
    """Three panels: cosine histograms per class, cosine against view difference, objects by distance."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(14, 4), dpi=100)
    FigureCanvasAgg(fig)
    ax1, ax2, ax3 = (fig.add_subplot(1, 3, k) for k in (1, 2, 3))
    d = grades.descriptors
    if d is not None:
        n = len(next(iter(d.classes.values())).hist)
        centres = np.linspace(-1, 1, n + 1)[:-1] + 1.0 / n
        for name, st in d.classes.items():
            if st.pairs:
                ax1.plot(centres, np.asarray(st.hist) / st.pairs, label=f"{name} ({st.pairs})")
        mids = 0.5 * (np.asarray(d.view_edges_deg[:-1]) + np.asarray(d.view_edges_deg[1:]))
        ax2.plot(mids, [np.nan if v is None else v for v in d.view_mean], "o-")
        ax1.legend(fontsize=7)
    ax1.set(xlabel="cosine", ylabel="share of pairs", title=f"descriptors: {grades.encoder or 'none'}")
    ax2.set(xlabel="view difference (deg)", ylabel="mean cosine, same instance", xlim=(0, 180))
    rows = grades.segmentation.by_distance()
    labels = [f"{r['from_m']:g}-{'' if r['to_m'] is None else format(r['to_m'], 'g')}" for r in rows]
    x = np.arange(len(rows))
    ax3.bar(x - 0.2, [r["objects"] for r in rows], 0.4, label="objects")
    ax3.bar(x + 0.2, [r["missed"] for r in rows], 0.4, label="missed")
    ax3.set_xticks(x, labels)
    s = grades.segmentation
    ax3.set(
        xlabel="object distance (m)",
        ylabel="object views",
        title=f"{grades.segmenter}: P {_f(s.precision)} R {_f(s.recall)} IoU {_f(s.mean_iou)}",
    )
    ax3.legend(fontsize=7)
    return save_png(fig, path)
