"""Top-down trajectory plot with loop-closure lines (matplotlib Agg, rendered to PNG and PDF bytes in memory).

Truth is drawn solid, the estimate dashed and odometry dotted, one colour per robot;
loop closures are lines between the two submap centres: intra-robot blue, inter-robot
green, wrong ones (``correct is False``) red dashed whatever their kind. The legend lists
the robots, layers and closure kinds drawn, nothing else.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import ArrayLike, NDArray

from roman_sim.core.errors import EvaluationError
from roman_sim.core.figures import figure_files
from roman_sim.core.trajectory import Trajectory
from roman_sim.evaluation.metrics import closure_correct
from roman_sim.mapping.types import Submap
from roman_sim.posegraph.types import LoopClosure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.typing import LineStyleType

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
#: (xyz_a, xyz_b, kind "intra" | "inter", correct True | False | None)
ClosureLine = tuple[ArrayLike, ArrayLike, str, bool | None]
#: What a trajectory layer takes per robot: a ``Trajectory``, poses ``T (N,4,4)`` or positions ``xyz (N,3)``.
TrajectoryLike = Trajectory | ArrayLike

CLOSURE_COLOURS = {"intra": "tab:blue", "inter": "tab:green"}
#: tab10 entries for robots: blue, green and red are left to the closure lines.
ROBOT_PALETTE = (1, 4, 5, 6, 7, 8, 9)
#: RGBA colour of a robot (a tab10 entry).
RGBA = tuple[float, float, float, float]


class LayerStyle(TypedDict, total=False):
    """Matplotlib line keywords of a trajectory layer (the colour is the robot's)."""

    linestyle: LineStyleType
    linewidth: float
    alpha: float


class LineStyle(LayerStyle, total=False):
    """Matplotlib line keywords of a closure line."""

    color: str


WRONG_STYLE: LineStyle = {"color": "tab:red", "linestyle": "--", "linewidth": 1.4, "alpha": 1.0}
LAYERS: dict[str, LayerStyle] = {  # name -> line style (matplotlib keywords) of that trajectory layer
    "truth": {"linestyle": "-", "linewidth": 1.6, "alpha": 0.9},
    "estimate": {"linestyle": "--", "linewidth": 1.3, "alpha": 0.9},
    "odometry": {"linestyle": ":", "linewidth": 1.2, "alpha": 0.8},
}


def _positions(value: TrajectoryLike, name: str) -> F64:
    """(N, 3) positions from a ``Trajectory``, ``T (N,4,4)`` or ``xyz (N,3)``."""
    if isinstance(value, Trajectory):
        return value.positions
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 3 and arr.shape[1:] == (4, 4):
        return arr[:, :3, 3]
    if arr.ndim == 2 and arr.shape[1] == 3:
        return arr
    raise EvaluationError(f"trajectory plot: {name} must be a Trajectory, T (N,4,4) or xyz (N,3); got {arr.shape}")


def robot_colours(robots: Sequence[str]) -> dict[str, RGBA]:
    """Each robot's colour (tab10, leaving blue, green and red to the closure lines), in the given order."""
    from matplotlib import colormaps

    cmap = colormaps["tab10"]
    palette = [cmap(i) for i in ROBOT_PALETTE]
    return {r: palette[i % len(palette)] for i, r in enumerate(robots)}


def _draw_layers(
    ax: Axes, colours: dict[str, RGBA], data: dict[str, Mapping[str, TrajectoryLike] | None]
) -> tuple[list[str], set[str]]:
    """Draw each given layer's trajectories (truth starts marked); returns the layers and robots with a pose drawn."""
    layers: list[str] = []
    robots: set[str] = set()
    for name, trajectories in data.items():
        for robot, value in (trajectories or {}).items():
            xyz = _positions(value, f"{name}[{robot}]")
            if not len(xyz):
                continue
            ax.plot(xyz[:, 0], xyz[:, 1], color=colours[robot], zorder=2, **LAYERS[name])
            if name == "truth":
                ax.plot(xyz[0, 0], xyz[0, 1], marker="o", color=colours[robot], zorder=3)
            if name not in layers:
                layers.append(name)
            robots.add(robot)
    return layers, robots


def _draw_closures(ax: Axes, closures: Sequence[ClosureLine]) -> set[str]:
    """Draw closure lines; returns the legend entries used."""
    used = set()
    for i, (xyz_a, xyz_b, kind, correct) in enumerate(closures):
        if kind not in CLOSURE_COLOURS:
            raise EvaluationError(f"closure {i}: kind {kind!r} unknown (valid: {', '.join(CLOSURE_COLOURS)})")
        a = np.asarray(xyz_a, dtype=np.float64).reshape(-1)
        b = np.asarray(xyz_b, dtype=np.float64).reshape(-1)
        if a.shape[0] < 2 or b.shape[0] < 2:
            raise EvaluationError(f"closure {i}: end points need at least x and y")
        style = WRONG_STYLE if correct is False else {"color": CLOSURE_COLOURS[kind], "linewidth": 0.8, "alpha": 0.7}
        ax.plot([a[0], b[0]], [a[1], b[1]], zorder=1, **style)
        used.add("wrong" if correct is False else kind)
    return used


def _without_alpha(style: LayerStyle) -> LayerStyle:
    out = style.copy()
    out.pop("alpha", None)
    return out


def _legend(ax: Axes, robots: dict[str, RGBA], layers: list[str], closure_kinds: set[str]) -> None:
    handles = [Line2D([], [], color=c, linewidth=2, label=r) for r, c in robots.items()]
    handles += [Line2D([], [], color="0.3", label=name, **_without_alpha(LAYERS[name])) for name in layers]
    if "truth" in layers:
        handles.append(Line2D([], [], color="0.3", marker="o", linestyle="none", label="start"))
    names = {"intra": "intra-robot closure", "inter": "inter-robot closure"}
    handles += [Line2D([], [], color=c, label=names[k]) for k, c in CLOSURE_COLOURS.items() if k in closure_kinds]
    if "wrong" in closure_kinds:
        handles.append(Line2D([], [], label="wrong closure", **WRONG_STYLE))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=4, fontsize=8, frameon=False)


def closure_lines(
    closures: Sequence[LoopClosure],
    weights: Sequence[float | None],
    submaps: Mapping[str, Submap],
    association_thresh: int,
    rot_tol_deg: float,
    trans_tol_m: float,
) -> list[ClosureLine]:
    """Lines of the closures a pose graph used, between the true submap centres, marked correct or wrong.

    A closure is drawn when the graph used it (its weight is not None) and it has at least
    ``association_thresh`` associations; it is correct when its relative pose is within the
    tolerances of the true one.
    """
    lines: list[ClosureLine] = []
    for c, w in zip(closures, weights):
        if w is None or c.n_associations < association_thresh:
            continue
        try:
            ok = closure_correct(c, submaps, rot_tol_deg, trans_tol_m)
        except EvaluationError as err:
            raise EvaluationError(f"trajectory plot: {err}") from None
        Ta = submaps[f"{c.robot_a}/{c.submap_a}"].truth.T_world_submap  # type: ignore[union-attr]
        Tb = submaps[f"{c.robot_b}/{c.submap_b}"].truth.T_world_submap  # type: ignore[union-attr]
        lines.append((Ta[:3, 3], Tb[:3, 3], "inter" if c.inter else "intra", ok))
    return lines


def trajectory_png(*args: Any, **kwargs: Any) -> bytes:
    """``trajectory_figure(*args, **kwargs)`` as PNG bytes."""
    return figure_files(trajectory_figure(*args, **kwargs), vector=False)[".png"]


def trajectory_figure(
    truth: Mapping[str, TrajectoryLike],
    est: Mapping[str, TrajectoryLike] | None = None,
    odom: Mapping[str, TrajectoryLike] | None = None,
    closures: Sequence[ClosureLine] = (),
    title: str = "",
    dpi: int = 120,
) -> Figure:
    """Robots' trajectories drawn top-down (x right, y up, metres) with loop-closure lines.

    Args:
        truth: robot -> ``Trajectory`` (or ``T (N,4,4)`` or ``xyz (N,3)``), all in the same
            frame (e.g. the world, or after alignment).
        est: optional estimates, as ``truth``.
        odom: optional odometry, as ``truth``.
        closures: ``(xyz_a, xyz_b, kind, correct)`` per closure line.
        title: figure title.
        dpi: resolution of the PNG.

    Raises:
        EvaluationError: nothing to draw, a malformed trajectory or closure line.
    """
    robots = list(dict.fromkeys([*truth, *(est or {}), *(odom or {})]))
    if not robots:
        raise EvaluationError("trajectory plot: no trajectories to draw")
    colours = robot_colours(robots)
    fig = Figure(figsize=(8.0, 7.0), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    layers, drawn = _draw_layers(ax, colours, {"truth": truth, "estimate": est, "odometry": odom})
    kinds = _draw_closures(ax, closures)
    _legend(ax, {r: c for r, c in colours.items() if r in drawn}, layers, kinds)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(True, linewidth=0.3)
    if title:
        ax.set_title(title)
    return fig
