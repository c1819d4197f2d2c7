"""Map view of segment maps, rendered offscreen with pyrender (EGL, headless).

Each segment is drawn as its points (when the submap carries them) or, without points,
as a box of its extents centred on its centre and aligned with the submap frame (an
approximation: submaps do not store box orientations). Colours are fixed per
(robot, segment id), so a segment seen in several submaps keeps its colour. The camera
looks down obliquely at the whole map from the south.
"""

from __future__ import annotations

import io
import logging
import zlib
from collections.abc import Callable
from colorsys import hsv_to_rgb
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh
from matplotlib.image import imsave
from numpy.typing import NDArray

from roman_sim.core.atomic import write_bytes
from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import make_T, transform_points
from roman_sim.core.glrender import offscreen_renderer
from roman_sim.mapping.types import Submap

log = logging.getLogger(__name__)

MapFrame = Literal["world", "odom"]


def _world_pose(s: Submap) -> NDArray[np.float64]:
    if s.truth is None:
        raise EvaluationError(f"submap {s.name}: no truth pose; draw it in the 'odom' frame instead")
    return s.truth.T_world_submap


#: How each frame places a submap: true world pose, or the robot's own odometry frame.
FRAMES: dict[str, Callable[[Submap], NDArray[np.float64]]] = {
    "world": _world_pose,
    "odom": lambda s: s.T_odom_submap,
}


def segment_colour(robot: str, segment_id: int) -> NDArray[np.float64]:
    """A stable, well-spread RGBA colour for one segment."""
    h = zlib.crc32(f"{robot}/{int(segment_id)}".encode()) / 2**32
    return np.array([*hsv_to_rgb(h, 0.75, 0.9), 1.0])


def _segment_points(s: Submap, i: int, cap: int) -> NDArray[np.float64] | None:
    if not s.points:
        return None
    p = np.asarray(s.points[i], dtype=np.float64).reshape(-1, 3)
    return p[:: max(1, -(-len(p) // cap))]  # deterministic stride down to at most ``cap``


def _geometry(submaps: list[Submap], frame: str, cap: int) -> tuple[list, list]:
    """(point clouds with colours, coloured box meshes) in the map frame."""
    clouds, boxes = [], []
    for s in submaps:
        T = FRAMES[frame](s)
        for i in range(len(s)):
            col = segment_colour(s.robot, s.segment_ids[i])
            pts = _segment_points(s, i, cap)
            if pts is not None and len(pts):
                clouds.append((transform_points(T, pts), col))
                continue
            box = trimesh.creation.box(extents=np.maximum(s.extents[i], 0.05))
            box.apply_transform(T @ make_T(None, s.centers[i]))
            box.visual.vertex_colors = np.tile((col * 255).astype(np.uint8), (len(box.vertices), 1))
            boxes.append(box)
    return clouds, boxes


def _ground(points: NDArray[np.float64]) -> trimesh.Trimesh:
    """A thin light-grey slab under the map, 2 m wider than it on each side."""
    lo, hi = points.min(0), points.max(0)
    slab = trimesh.creation.box(extents=[hi[0] - lo[0] + 4.0, hi[1] - lo[1] + 4.0, 0.02])
    slab.apply_translation([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2] - 0.05])
    slab.visual.vertex_colors = np.tile([205, 205, 195, 255], (len(slab.vertices), 1)).astype(np.uint8)
    return slab


def _look_at(eye: NDArray[np.float64], target: NDArray[np.float64]) -> NDArray[np.float64]:
    """Camera pose (pyrender: looks along -z, y up) at ``eye`` looking at ``target``."""
    z = eye - target
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    return make_T(np.stack([x, np.cross(z, x), z], 1), eye)


def _camera_pose(points: NDArray[np.float64], elevation_deg: float, fov: float) -> NDArray[np.float64]:
    lo, hi = points.min(0), points.max(0)
    target = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 1.0)
    dist = 1.1 * radius / np.tan(fov / 2)
    el = np.radians(elevation_deg)
    return _look_at(target + dist * np.array([0.0, -np.cos(el), np.sin(el)]), target)


def render_map(
    submaps: list[Submap],
    frame: MapFrame = "world",
    width: int = 640,
    height: int = 480,
    elevation_deg: float = 60.0,
    max_points_per_segment: int = 100,
) -> NDArray[np.uint8]:
    """Render the segments of ``submaps`` to an (height, width, 3) RGB image.

    Each segment is thinned to at most ``max_points_per_segment`` points: software
    rendering time grows with the point count (about 5 s for 160k points at 640x480 on
    two shared cores, see ``benchmarks/bench_evaluation.py``).

    Raises:
        EvaluationError: unknown frame, nothing to draw, or offscreen rendering failed.
    """
    if frame not in FRAMES:
        raise EvaluationError(f"unknown map frame {frame!r} (valid: {', '.join(FRAMES)})")
    if width < 8 or height < 8:
        raise EvaluationError(f"map view size must be at least 8x8, got {width}x{height}")
    clouds, boxes = _geometry(submaps, frame, max(1, max_points_per_segment))
    if not clouds and not boxes:
        raise EvaluationError("map view: the submaps hold no segments to draw")
    allpts = np.concatenate([c for c, _ in clouds] + [b.vertices for b in boxes])
    boxes = boxes + [_ground(allpts)]
    try:
        return _render(clouds, boxes, _camera_pose(allpts, elevation_deg, np.radians(45)), width, height)
    except EvaluationError:
        raise
    except Exception as err:  # EGL/OpenGL failures surface as many different types
        raise EvaluationError(f"offscreen map rendering failed: {type(err).__name__}: {err}") from None


def _render(clouds: list, boxes: list, cam_pose: NDArray[np.float64], width: int, height: int) -> NDArray[np.uint8]:
    import pyrender  # deferred: needs the EGL platform set by the package import

    scene = pyrender.Scene(bg_color=[0.96, 0.96, 0.94, 1.0], ambient_light=[0.45, 0.45, 0.45])
    if clouds:
        pts = np.concatenate([c for c, _ in clouds])
        cols = np.concatenate([np.tile(col, (len(c), 1)) for c, col in clouds])
        scene.add(pyrender.Mesh.from_points(pts, colors=cols))
    if boxes:
        scene.add(pyrender.Mesh.from_trimesh(trimesh.util.concatenate(boxes), smooth=False))
    scene.add(pyrender.PerspectiveCamera(yfov=np.radians(45), aspectRatio=width / height), pose=cam_pose)
    scene.add(pyrender.DirectionalLight(intensity=3.0), pose=cam_pose)
    renderer = offscreen_renderer(width, height)
    renderer.point_size = 3.0
    color, _ = renderer.render(scene)
    return np.ascontiguousarray(color[..., :3], dtype=np.uint8)


def map_view_png(submaps: list[Submap], **kwargs: object) -> bytes:
    """Render the map view (see ``render_map`` for options) as PNG bytes."""
    img = render_map(submaps, **kwargs)  # type: ignore[arg-type]
    buf = io.BytesIO()
    # None leaves the Software key out (same bytes everywhere); matplotlib's stub allows str only
    imsave(buf, img, format="png", metadata={"Software": None})  # type: ignore[dict-item]
    return buf.getvalue()


def write_map_view(path: str | Path, submaps: list[Submap], **kwargs: object) -> Path:
    """Render the map view (see ``render_map`` for options) and write it as a PNG atomically."""
    path = Path(path)
    write_bytes(path, map_view_png(submaps, **kwargs))
    log.info("wrote map view %s", path)
    return path
