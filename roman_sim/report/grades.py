"""The front end's grades for people: the report's markdown section and a three-panel figure."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from roman_sim.core.figures import drawn_legend, save_figure
from roman_sim.evaluation.grades import FrontEndGrades


def _f(v: float | None, digits: int = 2) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def frontend_report_lines(grades: FrontEndGrades) -> list[str]:
    """The report's front-end section (markdown lines): grades within the depth range, by distance, cosines."""
    s = grades.segmentation
    far = s.far()
    lines = [
        "## Front end against truth",
        "",
        f"Segmenter `{grades.segmenter}`, encoder `{grades.encoder or 'none'}`, graded on {s.frames} frames "
        "against the instance image (objects in ROMAN's mask area window, after its erosion). Headline: "
        f"objects and masks within the mapper's {s.max_depth_m:g} m depth range.",
        "",
        "| | precision | recall | mean IoU | masks / frame | over-segmented | under-segmented | spurious |",
        "|---|---|---|---|---|---|---|---|",
        f"| within {s.max_depth_m:g} m | {_f(s.precision)} | {_f(s.recall)} | {_f(s.mean_iou)} | "
        f"{_f(s.masks / max(s.frames, 1), 1)} | {s.over_segmented} | {s.under_segmented} of "
        f"{s.touching_pairs} touching pairs | {s.spurious} |",
        f"| beyond (not mapped) | {_f(far.precision)} | {_f(far.recall)} | {_f(far.mean_iou)} | | | | |",
        f"| every depth | {_f(s.precision_all)} | {_f(s.recall_all)} | {_f(s.mean_iou_all)} | | | | |",
        "",
    ]
    rows = s.by_distance()
    if rows:
        lines += [
            "| object distance (m) | object views | missed | recall (IoU match) | masks | precision | mean IoU |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in rows:
            to = "" if r.to_m is None else f"{r.to_m:g}"
            label = f"{r.from_m:g}-{to}" + ("" if r.in_range else " (beyond range)")
            lines.append(
                f"| {label} | {r.objects} | {r.missed} | {_f(r.recall)} | {r.masks} | "
                f"{_f(r.precision)} | {_f(r.mean_iou)} |"
            )
        lines.append("")
    d = grades.descriptors
    if d is not None:
        lines += [
            f"| descriptor pairs | pairs | mean cosine | 5 % | 95 % | at or above {d.gate_cos:g} |",
            "|---|---|---|---|---|---|",
        ]
        for name, st in d.classes.items():
            lines.append(
                f"| {name.replace('_', ' ')} | {st.pairs} | {_f(st.mean)} | {_f(st.p05)} | {_f(st.p95)} | "
                f"{_f(st.frac_above_gate)} |"
            )
        above, pairs = d.other_family_above_gate()
        share = "n/a" if not pairs else f"{above / pairs:.3f} ({above} of {pairs})"
        lines += ["", f"Other-family pairs passing the {d.gate_cos:g} semantic gate: {share}.", ""]
        if d.sides:
            lines += [
                f"| relation (one side: views within 45 deg) | pairs | mean cosine | at or above {d.gate_cos:g} |"
            ]
            lines += ["|---|---|---|---|"]
            for name, st in d.sides.items():
                lines.append(f"| {name.replace('_', ' ')} | {st.pairs} | {_f(st.mean)} | {_f(st.frac_above_gate)} |")
            lines.append("")
        if d.appearance:
            lines += [
                f"| two instances of one family, one side: appearance difference | pairs | mean cosine | "
                f"at or above {d.gate_cos:g} |",
                "|---|---|---|---|",
            ]
            e = d.appearance_edges
            for k, st in enumerate(d.appearance):
                lines.append(f"| {e[k]:g}-{e[k + 1]:g} | {st.pairs} | {_f(st.mean)} | {_f(st.frac_above_gate)} |")
            lines.append("")
    return lines


def plot_frontend_grades(grades: FrontEndGrades, path: str | Path) -> Path:
    """Three panels: cosine histograms per class, cosine against view difference, objects by distance."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 4), dpi=100)
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
        drawn_legend(ax1, fontsize=7)
    ax1.set(xlabel="cosine", ylabel="share of pairs", title=f"descriptors: {grades.encoder or 'none'}")
    ax2.set(
        xlabel="view difference (deg)",
        ylabel="mean cosine, same instance",
        xlim=(0, 180),
        title="same instance against view difference",
    )
    rows = grades.segmentation.by_distance()
    labels = [f"{r.from_m:g}-{'' if r.to_m is None else format(r.to_m, 'g')}" for r in rows]
    x = np.arange(len(rows))
    ax3.bar(x - 0.2, [r.objects for r in rows], 0.4, label="objects")
    ax3.bar(x + 0.2, [r.missed for r in rows], 0.4, label="missed")
    ax3.set_xticks(x, labels)
    s = grades.segmentation
    ax3.set(
        xlabel="object distance (m)",
        ylabel="object views",
        title=f"{grades.segmenter}: P {_f(s.precision)} R {_f(s.recall)} IoU {_f(s.mean_iou)}",
    )
    drawn_legend(ax3, fontsize=7)
    return save_figure(fig, path)
