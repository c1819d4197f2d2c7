"""World previews: a top-down map with families coloured (PNG, and a PDF beside it) and one rendered RGB view."""

from __future__ import annotations

import io
import logging
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PatchCollection
from matplotlib.figure import Figure
from matplotlib.image import imsave
from matplotlib.legend_handler import HandlerPolyCollection
from matplotlib.patches import Circle
from numpy.typing import NDArray

from roman_sim.core.atomic import output_file, output_folder, write_bytes
from roman_sim.core.errors import ConfigError, WorldError
from roman_sim.core.figures import PNG, figure_files, save_figure, vector_path
from roman_sim.world.build import World
from roman_sim.world.truth import WorldTruth

log = logging.getLogger(__name__)

#: How the top-down map is saved: cropped to what is drawn.
SAVE: dict[str, Any] = {"tight_layout": False, "bbox_inches": "tight"}


def topdown_png(truth: WorldTruth, title: str = "", road_width_m: float = 0.0) -> bytes:
    """PNG bytes of a top-down map: terrain shading, roads (to scale), footprints by family."""
    return figure_files(topdown_figure(truth, title, road_width_m), vector=False, **SAVE)[PNG]


def topdown_figure(truth: WorldTruth, title: str = "", road_width_m: float = 0.0) -> Figure:
    """The top-down map: terrain shading, roads (to scale), footprints by family (the legend lists each family
    drawn, with its count)."""
    t = truth.terrain
    fig = Figure(figsize=(8, 8 * t.size_y / t.size_x + 0.5), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ext = (-t.size_x / 2, t.size_x / 2, -t.size_y / 2, t.size_y / 2)
    ax.set(xlim=ext[:2], ylim=ext[2:], aspect="equal")
    ax.imshow(t.heights, origin="lower", extent=ext, cmap="Greys", alpha=0.5)
    points_per_m = ax.get_window_extent().width / t.size_x * 72.0 / fig.dpi
    for road in truth.roads:
        ax.plot(
            road[:, 0],
            road[:, 1],
            color="sienna",
            lw=max(1.0, road_width_m * points_per_m),
            alpha=0.5,
            solid_capstyle="butt",
        )
    cmap = colormaps["tab20"]
    for k, fam in enumerate(truth.families()):
        objs = [o for o in truth.objects if o.family == fam]
        circles = [Circle(tuple(o.T_world_obj[:2, 3]), o.radius) for o in objs]
        if circles:  # the family's footprints carry its legend entry: a family without one is not listed
            coll = PatchCollection(circles, facecolor=cmap(k % 20), edgecolor="k", lw=0.3, alpha=0.85)
            coll.set_label(f"{fam} ({len(objs)})")
            ax.add_collection(coll)
    ax.set(xlim=ext[:2], ylim=ext[2:], xlabel="x [m]", ylabel="y [m]", aspect="equal", title=title)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=7, framealpha=0.8, handler_map={PatchCollection: HandlerPolyCollection()})
    return fig


def render_view(
    world: World,
    width: int = 640,
    height: int = 480,
    azimuth_deg: float = 45.0,
    elevation_deg: float = -25.0,
    distance_frac: float = 0.45,
) -> NDArray[np.uint8]:
    """(H, W, 3) RGB image from a free camera looking at the world centre."""
    model = world.model
    max_w, max_h = model.vis.global_.offwidth, model.vis.global_.offheight
    if not (16 <= width <= max_w and 16 <= height <= max_h):
        raise WorldError(f"preview size {width}x{height}: width must be in [16, {max_w}] and height in [16, {max_h}]")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    t = world.truth.terrain
    cam.lookat[:] = [0.0, 0.0, float(t.height_at(0.0, 0.0))]
    cam.distance = distance_frac * max(t.size_x, t.size_y)
    cam.azimuth, cam.elevation = azimuth_deg, elevation_deg
    with mujoco.Renderer(model, height, width) as renderer:
        renderer.update_scene(data, camera=cam)
        return renderer.render().copy()


def _png(rgb: NDArray[np.uint8]) -> bytes:
    buf = io.BytesIO()
    imsave(buf, rgb, format="png")
    return buf.getvalue()


def preview_paths(out: str | Path, what: str = "out") -> tuple[Path, Path]:
    """The (top-down, view) PNG paths for ``out``, checked writable (``ConfigError`` naming ``what``).

    ``X.png`` gives ``X.png`` (with ``X.pdf``, its vector copy) and ``X_view.png``; anything
    else is a folder that receives ``topdown.png`` (with ``topdown.pdf``) and ``view.png``.
    Nothing is created.
    """
    out = Path(out)
    if out.suffix.lower() == ".png":
        top, view = out, out.with_name(out.stem + "_view.png")
        for p in (top, vector_path(top), view):
            output_file(p, what, create=False)
    else:
        output_folder(out, what, create=False)
        top, view = out / "topdown.png", out / "view.png"
        for p in (top, vector_path(top), view):
            if p.is_dir():
                raise ConfigError(f"{what} {out}: {p.name} there is a folder, cannot write the preview")
    return top, view


def write_preview(world: World, out: str | Path, width: int = 640, height: int = 480) -> list[Path]:
    """Write ``topdown.png``, ``topdown.pdf`` and ``view.png`` into folder ``out``, or ``X.png``, ``X.pdf`` and
    ``X_view.png``; returns the paths written."""
    top, view = preview_paths(out)
    title = f"{world.spec.name} (seed {world.seed}, {len(world.truth.objects)} objects)"
    save_figure(topdown_figure(world.truth, title, world.spec.roads.width_m), top, **SAVE)
    write_bytes(view, _png(render_view(world, width, height)))
    log.info("preview written to %s, %s and %s", top, vector_path(top), view)
    return [top, vector_path(top), view]
