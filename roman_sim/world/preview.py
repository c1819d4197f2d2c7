"""World previews: a top-down map with families coloured and one rendered RGB view."""

from __future__ import annotations

import io
import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PatchCollection  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from roman_sim.core.atomic import output_file, output_folder, write_bytes  # noqa: E402
from roman_sim.core.errors import ConfigError, WorldError  # noqa: E402
from roman_sim.world.build import World  # noqa: E402
from roman_sim.world.truth import WorldTruth  # noqa: E402

log = logging.getLogger(__name__)


def topdown_png(truth: WorldTruth, title: str = "", road_width_m: float = 0.0) -> bytes:
    """PNG bytes of a top-down map: terrain shading, roads (to scale), footprints by family."""
    t = truth.terrain
    fig, ax = plt.subplots(figsize=(8, 8 * t.size_y / t.size_x + 0.5), dpi=100)
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
    cmap = plt.get_cmap("tab20")
    for k, fam in enumerate(truth.families()):
        objs = [o for o in truth.objects if o.family == fam]
        circles = [Circle(tuple(o.T_world_obj[:2, 3]), o.radius) for o in objs]
        ax.add_collection(PatchCollection(circles, facecolor=cmap(k % 20), edgecolor="k", lw=0.3, alpha=0.85))
        ax.plot([], [], "o", color=cmap(k % 20), label=f"{fam} ({len(objs)})")
    ax.set(xlim=ext[:2], ylim=ext[2:], xlabel="x [m]", ylabel="y [m]", aspect="equal", title=title)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


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
    plt.imsave(buf, rgb, format="png")
    return buf.getvalue()


def preview_paths(out: str | Path, what: str = "out") -> tuple[Path, Path]:
    """The (top-down, view) PNG paths for ``out``, checked writable (``ConfigError`` naming ``what``).

    ``X.png`` gives ``X.png`` and ``X_view.png``; anything else is a folder that receives
    ``topdown.png`` and ``view.png``. Nothing is created.
    """
    out = Path(out)
    if out.suffix.lower() == ".png":
        top, view = out, out.with_name(out.stem + "_view.png")
        output_file(top, what, create=False)
        output_file(view, what, create=False)
    else:
        output_folder(out, what, create=False)
        top, view = out / "topdown.png", out / "view.png"
        for p in (top, view):
            if p.is_dir():
                raise ConfigError(f"{what} {out}: {p.name} there is a folder, cannot write the preview")
    return top, view


def write_preview(world: World, out: str | Path, width: int = 640, height: int = 480) -> list[Path]:
    """Write ``topdown.png`` and ``view.png`` into folder ``out``, or ``X.png`` and ``X_view.png``."""
    top, view = preview_paths(out)
    title = f"{world.spec.name} (seed {world.seed}, {len(world.truth.objects)} objects)"
    write_bytes(top, topdown_png(world.truth, title, world.spec.roads.width_m))
    write_bytes(view, _png(render_view(world, width, height)))
    log.info("preview written to %s and %s", top, view)
    return [top, view]
