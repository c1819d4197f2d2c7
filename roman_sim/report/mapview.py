"""Map view of a run's segment maps: a top-down figure in metres (matplotlib, Agg canvas).

Top-down rather than a 3D render: submaps are gravity-aligned and alignment is judged in x,
y and yaw, and a figure a paper can use needs metric axes, a scale bar and a legend, which a
perspective render has none of. Matplotlib also gives the same bytes on every machine
(no OpenGL driver involved).

What is drawn, one colour per robot (the trajectory plot's colours):

- each segment once, from the last submap that holds it (the one that saw it longest),
  as a circle to scale (diameter: the mean of its two largest box extents) at its centre;
  filled when its majority true object is known, hollow when it has none (a spurious
  segment: terrain, sky, a merge);
- the segment's points, when the submaps carry them, as small dots under the circles;
- the robot's submap centres joined in visiting order (the path the robot mapped along).

In the ``world`` frame every submap is placed by its true pose; in ``odom`` by the robot's
own odometry (robots' frames then differ).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Literal

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import EllipseCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from numpy.typing import NDArray

from roman_sim.core.errors import EvaluationError
from roman_sim.core.figures import FigureFiles, figure_files, save_figure
from roman_sim.core.geometry import transform_points
from roman_sim.mapping.types import Submap
from roman_sim.report.plots import figure
from roman_sim.report.trajplot import RGBA, robot_colours

log = logging.getLogger(__name__)

MapFrame = Literal["world", "odom"]

#: Smallest circle drawn (m): a segment of a few points still shows.
MIN_DIAMETER_M = 0.3


def _world_pose(s: Submap) -> NDArray[np.float64]:
    if s.truth is None:
        raise EvaluationError(f"submap {s.name}: no truth pose; draw it in the 'odom' frame instead")
    return s.truth.T_world_submap


#: How each frame places a submap: true world pose, or the robot's own odometry frame.
FRAMES: dict[str, Callable[[Submap], NDArray[np.float64]]] = {
    "world": _world_pose,
    "odom": lambda s: s.T_odom_submap,
}


class _Segments:
    """One robot's segments, each once (from the last submap holding it), in the map frame."""

    def __init__(self) -> None:
        self.latest: dict[int, tuple[NDArray[np.float64], float, int, NDArray[np.float64] | None]] = {}

    def add(self, s: Submap, T: NDArray[np.float64], cap: int) -> None:
        centres = transform_points(T, np.asarray(s.centers, dtype=np.float64).reshape(-1, 3))
        ext = np.asarray(s.extents, dtype=np.float64).reshape(-1, 3)
        for i, sid in enumerate(np.asarray(s.segment_ids).tolist()):
            obj = -2 if s.truth is None else int(s.truth.object_ids[i])  # -2: no truth, -1: no true object
            pts = None
            if s.points:
                p = np.asarray(s.points[i], dtype=np.float64).reshape(-1, 3)
                pts = transform_points(T, p[:: max(1, -(-len(p) // cap))]) if len(p) else None
            self.latest[int(sid)] = (centres[i], max(float(ext[i, :2].mean()), MIN_DIAMETER_M), obj, pts)


def _collect(
    submaps: list[Submap], frame: str, cap: int
) -> tuple[dict[str, _Segments], dict[str, NDArray[np.float64]]]:
    """Per robot: its segments and its submap centres in visiting order, in ``frame``."""
    segs: dict[str, _Segments] = {}
    path: dict[str, list[tuple[int, NDArray[np.float64]]]] = {}
    for s in sorted(submaps, key=lambda s: (s.robot, s.index)):
        T = FRAMES[frame](s)
        segs.setdefault(s.robot, _Segments()).add(s, T, cap)
        path.setdefault(s.robot, []).append((s.index, T[:3, 3]))
    return segs, {r: np.array([p for _, p in v]) for r, v in path.items()}


def _nice_length(span: float) -> float:
    """A round scale-bar length (1, 2 or 5 times a power of ten) near a fifth of ``span``."""
    target = max(span / 5.0, 1e-3)
    power = 10.0 ** np.floor(np.log10(target))
    return float(max(m * power for m in (1.0, 2.0, 5.0) if m * power <= target))


def _scale_bar(ax: Axes, lo: NDArray[np.float64], hi: NDArray[np.float64]) -> float:
    """A black bar with its length in metres, in the lower left corner; returns the length."""
    span = hi - lo
    length = _nice_length(float(span[0]))
    x0, y0 = lo[0] + 0.04 * span[0], lo[1] + 0.04 * span[1]
    ax.plot([x0, x0 + length], [y0, y0], color="black", linewidth=3, solid_capstyle="butt", zorder=5)
    ax.text(x0 + length / 2, y0 + 0.015 * span[1], f"{length:g} m", ha="center", va="bottom", fontsize=8, zorder=5)
    return length


def _draw_robot(ax: Axes, segs: _Segments, path: NDArray[np.float64], colour: RGBA) -> tuple[bool, bool, bool]:
    """Draw one robot's points, circles and path; returns (points, filled circles, hollow circles) drawn."""
    rows = list(segs.latest.values())
    pts = [p for _, _, _, p in rows if p is not None]
    if pts:
        cloud = np.concatenate(pts)
        ax.scatter(cloud[:, 0], cloud[:, 1], s=0.4, color=colour, alpha=0.35, linewidths=0, zorder=1)
    xy = np.array([c[:2] for c, _, _, _ in rows]).reshape(-1, 2)
    d = np.array([dia for _, dia, _, _ in rows])
    known = np.array([obj != -1 for _, _, obj, _ in rows], dtype=bool)
    for mask, face in ((known, (*colour[:3], 0.55)), (~known, "none")):
        if mask.any():
            ax.add_collection(
                EllipseCollection(
                    d[mask],
                    d[mask],
                    np.zeros(int(mask.sum())),
                    units="xy",
                    offsets=xy[mask],
                    offset_transform=ax.transData,
                    facecolors=[face],
                    edgecolors=[colour],
                    linewidths=0.8,
                    zorder=2,
                )
            )
    ax.plot(path[:, 0], path[:, 1], color=colour, linewidth=1.0, marker="o", markersize=2.5, alpha=0.8, zorder=3)
    return bool(pts), bool(known.any()), bool((~known).any())


def _legend(ax: Axes, colours: dict[str, RGBA], points: bool, filled: bool, hollow: bool, truth: bool) -> None:
    """The legend of what was drawn: robots, filled and hollow circles and points (those drawn), submap centres."""
    handles: list[Line2D | Patch] = [Patch(facecolor=c, edgecolor=c, label=f"robot {r}") for r, c in colours.items()]
    seg = "segment, circle to scale" + (" (true object known)" if truth else "")
    if filled:
        handles.append(Patch(facecolor="0.6", edgecolor="0.3", label=seg))
    if hollow:
        handles.append(Patch(facecolor="none", edgecolor="0.3", label="segment with no true object"))
    if points:
        handles.append(Line2D([], [], color="0.3", marker=".", linestyle="none", label="segment points"))
    handles.append(Line2D([], [], color="0.3", marker="o", markersize=2.5, label="submap centres, in order"))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=3, fontsize=8, frameon=False)


def map_view_figure(
    submaps: list[Submap], frame: MapFrame = "world", title: str = "", max_points_per_segment: int = 100
) -> Figure:
    """The top-down map view of ``submaps`` (see the module docstring) as a matplotlib figure.

    Each segment's points are thinned to at most ``max_points_per_segment`` (a
    deterministic stride). ``title`` is put before the figure's own description.

    Raises:
        EvaluationError: unknown frame, a submap without truth in the ``world`` frame, or
            nothing to draw.
    """
    if frame not in FRAMES:
        raise EvaluationError(f"unknown map frame {frame!r} (valid: {', '.join(FRAMES)})")
    segs, paths = _collect(submaps, frame, max(1, max_points_per_segment))
    n_segments = sum(len(s.latest) for s in segs.values())
    if not n_segments:
        raise EvaluationError("map view: the submaps hold no segments to draw")
    colours = robot_colours(list(segs))
    fig = figure(8.0, 8.0)
    ax = fig.axes[0]
    drawn = np.zeros(3, dtype=bool)  # points, filled circles, hollow circles
    extent: list[NDArray[np.float64]] = []
    for robot, s in segs.items():
        drawn |= _draw_robot(ax, s, paths[robot], colours[robot])
        extent += [paths[robot][:, :2], *(c[:2] + np.array([[-d, -d], [d, d]]) / 2 for c, d, _, _ in s.latest.values())]
    allxy = np.concatenate(extent)
    lo, hi = allxy.min(0), allxy.max(0)
    pad = 0.05 * max(float((hi - lo).max()), 1.0)
    lo, hi = lo - pad, hi + pad
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), xlabel="x (m)", ylabel="y (m)")
    ax.set_aspect("equal", adjustable="box")
    ax.grid(True, linewidth=0.3, alpha=0.5)
    _scale_bar(ax, lo, hi)
    truth = all(s.truth is not None for s in submaps)
    points, filled, hollow = (bool(d) for d in drawn)
    _legend(ax, colours, points, filled, hollow, truth)
    where = "true submap poses" if frame == "world" else "each robot's odometry frame"
    head = f"{title}: segment maps" if title else "Segment maps"
    ax.set_title(f"{head} from above ({where})\n{n_segments} segments in {len(submaps)} submaps", fontsize=10)
    return fig


def write_map_view(path: str | Path, submaps: list[Submap], **kwargs: object) -> Path:
    """Draw the map view (see ``map_view_figure`` for options) and write it atomically as a PNG at ``path`` and
    a PDF beside it (its points drawn as an image inside the PDF)."""
    out = save_figure(map_view_figure(submaps, **kwargs), path)  # type: ignore[arg-type]
    log.info("wrote map view %s", out)
    return out


def map_view_files(submaps: list[Submap], **kwargs: object) -> FigureFiles:
    """The map view (see ``map_view_figure`` for options) as PNG and PDF bytes."""
    return figure_files(map_view_figure(submaps, **kwargs))  # type: ignore[arg-type]


def map_view_png(submaps: list[Submap], **kwargs: object) -> bytes:
    """The map view (see ``map_view_figure`` for options) as PNG bytes."""
    return figure_files(map_view_figure(submaps, **kwargs), vector=False)[".png"]  # type: ignore[arg-type]
