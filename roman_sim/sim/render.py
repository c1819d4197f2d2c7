"""Headless RGB, metric depth and instance-id rendering of a world with MuJoCo.

The world is static, so the MuJoCo scene is built once (``mjv_updateScene``); each frame
only overwrites the OpenGL camera (pose and an off-centre frustum matching the pinhole
intrinsics) and renders. Depth and instance ids come from one segmentation pass (the
depth buffer and the id colours are read together); RGB is a second pass when asked for.

The software rasteriser spends most of a pass transforming vertices, so mesh geoms whose
bounding sphere lies wholly outside the camera's frustum are not drawn (their display list
is skipped: ``dataid`` -1). Such a geom gives no fragment, so the images are the same bits.
The RGB pass culls too unless something outside the frustum can show in it: a shadow map
or a reflective geom.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import mujoco
import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import SimError
from roman_sim.core.sensors import Intrinsics
from roman_sim.sim.camera import CameraConfig
from roman_sim.world.relight import RobotLighting, apply_lighting

if TYPE_CHECKING:
    from roman_sim.world import World

log = logging.getLogger(__name__)

RenderOutput = tuple[NDArray[np.uint8] | None, NDArray[np.float32], NDArray[np.int32]]


class SensorRenderer:
    """Renders one camera of one world; ``render(T_world_cam)`` -> (rgb, depth, object_ids).

    Args:
        world: anything with ``.model`` (compiled ``mujoco.MjModel``) and ``.truth``
            (``WorldTruth``, for the geom -> object id table).
        camera_cfg: camera configuration (intrinsics, near/far planes).
        rgb: whether ``render`` also returns an RGB image by default (costs one more pass;
            ``render(T, rgb=...)`` decides per frame).
        lighting: this camera's own lighting (``roman_sim.world.relight``); None: the world's.
        cull: skip drawing the mesh geoms outside the frustum (the same images; False draws all).
    """

    def __init__(
        self,
        world: World,
        camera_cfg: CameraConfig,
        rgb: bool = True,
        lighting: RobotLighting | None = None,
        cull: bool = True,
    ) -> None:
        self.cfg = camera_cfg
        self.intrinsics: Intrinsics = camera_cfg.intrinsics()
        self.rgb = rgb
        model: mujoco.MjModel = world.model
        w, h = self.intrinsics.width, self.intrinsics.height
        if w > model.vis.global_.offwidth or h > model.vis.global_.offheight:
            raise SimError(
                f"camera {w}x{h} exceeds the world's offscreen buffer "
                f"{model.vis.global_.offwidth}x{model.vis.global_.offheight}"
            )
        self._model = model
        self._near, self._far = float(camera_cfg.near_m), float(camera_cfg.far_m)
        self._gl = mujoco.GLContext(w, h)
        self._gl.make_current()
        # No multisampling: resolving MSAA would blend id colours at object edges (wrong ids)
        # and costs about 2x in software rendering. The setting is read only here.
        samples = model.vis.quality.offsamples
        model.vis.quality.offsamples = 0
        try:
            self._ctx: mujoco.MjrContext | None = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        finally:
            model.vis.quality.offsamples = samples
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._ctx)
        self._ctx.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._rect = mujoco.MjrRect(0, 0, w, h)
        self._scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom + 100))
        self._build_scene()
        if lighting is not None:
            apply_lighting(model, self._scene, self._ctx, lighting)
        self._seg_lut = self._segid_to_object(world.truth.geom_to_object(model.ngeom))
        self._rgb_buf = np.empty((h, w, 3), dtype=np.uint8)
        self._rgba_buf = np.empty((h, w, 4), dtype=np.uint8)
        self._depth_buf = np.empty((h, w), dtype=np.float32)
        self._cull = _FrustumCull(self._scene, self._ctx, self.intrinsics, self._near, self._far, cull)

    def _build_scene(self) -> None:
        data = mujoco.MjData(self._model)
        mujoco.mj_forward(self._model, data)
        opt = mujoco.MjvOption()
        cam = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(self._model, cam)
        mujoco.mjv_updateScene(self._model, data, opt, None, cam, mujoco.mjtCatBit.mjCAT_ALL, self._scene)

    def _segid_to_object(self, geom_lut: NDArray[np.int32]) -> NDArray[np.int32]:
        """Table from id colour (segid + 1; 0 = nothing drawn) to object id (-1 background)."""
        n = self._scene.ngeom
        lut = np.full(n + 2, -1, dtype=np.int32)
        for i in range(n):
            g = self._scene.geoms[i]
            if g.objtype == mujoco.mjtObj.mjOBJ_GEOM and 0 <= g.objid < len(geom_lut) and g.segid >= 0:
                lut[g.segid + 1] = geom_lut[g.objid]
        return lut

    def _set_camera(self, T_world_cam: NDArray[np.float64]) -> None:
        """Point both scene cameras along the RDF optical frame with the pinhole frustum."""
        T = np.asarray(T_world_cam, dtype=np.float64)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise SimError(f"render: T_world_cam must be a finite 4x4 pose, got shape {T.shape}")
        k, n = self.intrinsics, self._near
        left = (-0.5 - k.cx) * n / k.fx
        right = (k.width - 0.5 - k.cx) * n / k.fx
        top = (k.cy + 0.5) * n / k.fy
        bottom = -(k.height - 0.5 - k.cy) * n / k.fy
        for cam in (self._scene.camera[0], self._scene.camera[1]):
            cam.pos[:] = T[:3, 3]
            cam.forward[:] = T[:3, 2]
            cam.up[:] = -T[:3, 1]
            cam.frustum_near = n
            cam.frustum_far = self._far
            cam.frustum_center = (left + right) / 2
            cam.frustum_width = (right - left) / 2
            cam.frustum_bottom = bottom
            cam.frustum_top = top
            cam.orthographic = 0

    def render(self, T_world_cam: NDArray[np.float64], rgb: bool | None = None) -> RenderOutput:
        """Render from a camera (RDF optical frame) pose.

        Args:
            T_world_cam: 4x4 camera pose.
            rgb: draw the RGB pass for this frame (None: the renderer's default).

        Returns:
            rgb (H, W, 3) uint8 or None, noise-free depth (H, W) float32 in metres along
            the optical axis (0 where nothing is hit within the far plane), and object ids
            (H, W) int32 (-1 for terrain and sky).
        """
        if self._ctx is None:
            raise SimError("render: renderer is closed")
        self._gl.make_current()
        self._set_camera(T_world_cam)
        self._cull.show(np.asarray(T_world_cam, dtype=np.float64))
        depth, ids = self._render_depth_ids()
        if not (self.rgb if rgb is None else rgb):
            return None, depth, ids
        return self._rgb_pass(), depth, ids

    def render_rgb(self, T_world_cam: NDArray[np.float64]) -> NDArray[np.uint8]:
        """Only the RGB image from a camera pose: a second camera of the same intrinsics (stereo).

        Returns: (H, W, 3) uint8, drawn as ``render`` draws its RGB pass.
        """
        if self._ctx is None:
            raise SimError("render: renderer is closed")
        self._gl.make_current()
        self._set_camera(T_world_cam)
        self._cull.show(np.asarray(T_world_cam, dtype=np.float64))
        return self._rgb_pass()

    def _rgb_pass(self) -> NDArray[np.uint8]:
        """The RGB pass for the camera and culling set up last."""
        self._cull.show_for_rgb()
        mujoco.mjr_render(self._rect, self._scene, self._ctx)
        mujoco.mjr_readPixels(self._rgb_buf, None, self._rect, self._ctx)
        return self._rgb_buf[::-1].copy()

    def _render_depth_ids(self) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
        flags = self._scene.flags
        saved = flags.copy()
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
        flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        try:
            mujoco.mjr_render(self._rect, self._scene, self._ctx)
            mujoco.mjr_readPixels(self._rgb_buf, self._depth_buf, self._rect, self._ctx)
        finally:
            np.copyto(flags, saved)
        import cv2  # imported on use: loading the pipeline should not import OpenCV

        # id colour (r, g, b) -> r | g << 8 | b << 16: as RGBA, one little-endian uint32 per pixel
        cv2.cvtColor(self._rgb_buf, cv2.COLOR_RGB2RGBA, dst=self._rgba_buf)
        seg = self._rgba_buf.view("<u4")[..., 0]
        seg &= 0xFFFFFF
        np.minimum(seg, len(self._seg_lut) - 1, out=seg)
        # OpenGL rows run bottom-up
        return self._linear_depth(self._depth_buf[::-1]), self._seg_lut.take(seg[::-1])

    def _linear_depth(self, zbuf: NDArray[np.float32]) -> NDArray[np.float32]:
        """Reversed-Z depth buffer (1 near, 0 far) -> metric depth; far/sky -> 0."""
        n, f = np.float32(self._near), np.float32(self._far)
        c = -(f + n) / (f - n)
        d = -(np.float32(2) * f * n) / (f - n)
        c, d = np.float32(-0.5) * c - np.float32(0.5), np.float32(-0.5) * d
        depth = zbuf + c
        with np.errstate(divide="ignore"):
            np.divide(d, depth, out=depth)
        far = zbuf <= 0
        far |= depth >= f * np.float32(0.999)
        depth[far] = 0.0
        return depth.astype(np.float32, copy=False)

    def close(self) -> None:
        """Free the OpenGL resources (idempotent)."""
        if self._ctx is not None:
            self._gl.make_current()
            self._ctx.free()
            self._ctx = None
            self._gl.free()

    def __enter__(self) -> "SensorRenderer":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _FrustumCull:
    """Skips drawing the mesh geoms of a static scene that lie outside the camera's frustum.

    A geom is kept when its bounding sphere (``modelrbound`` about its centre, grown by 1 % and
    1 mm) reaches into the frustum, tested against a symmetric frustum as wide as the widest
    side of the real one: a conservative test, it never drops a geom that could be seen.
    """

    def __init__(
        self, scene: mujoco.MjvScene, ctx: mujoco.MjrContext, k: Intrinsics, near: float, far: float, on: bool = True
    ) -> None:
        self._scene = scene
        geoms = [scene.geoms[i] for i in range(scene.ngeom)]
        self._pos = np.array([g.pos for g in geoms], dtype=np.float64).reshape(-1, 3)
        self._radius = np.array([g.modelrbound for g in geoms], dtype=np.float64) * 1.01 + 1e-3
        self._dataid = np.array([g.dataid for g in geoms], dtype=np.int64)
        mesh = np.array([g.type == mujoco.mjtGeom.mjGEOM_MESH for g in geoms], dtype=bool)
        self._cullable = mesh & (self._dataid >= 0) & on
        self._shown = np.ones(len(geoms), dtype=bool)
        self._near, self._far = near, far
        self._tan = np.array(
            [
                max(abs(-0.5 - k.cx), abs(k.width - 0.5 - k.cx)) / k.fx,
                max(abs(-0.5 - k.cy), abs(k.height - 0.5 - k.cy)) / k.fy,
            ]
        )
        self._norm = np.hypot(1.0, self._tan)
        reflective = any(
            g.type in (mujoco.mjtGeom.mjGEOM_PLANE, mujoco.mjtGeom.mjGEOM_BOX) and g.reflectance > 0 for g in geoms
        )
        shadows = bool(ctx.shadowFBO) and bool(scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW])
        self._rgb_ok = not (reflective or shadows)
        log.debug("frustum culling of %d mesh geoms (RGB pass too: %s)", int(self._cullable.sum()), self._rgb_ok)

    def visible(self, T_world_cam: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Geoms to draw from the camera pose ``T_world_cam`` (RDF optical frame)."""
        p = (self._pos - T_world_cam[:3, 3]) @ T_world_cam[:3, :3]
        r = self._radius
        z = p[:, 2]
        inside = (z + r >= self._near) & (z - r <= self._far)
        for axis in (0, 1):
            inside &= (np.abs(p[:, axis]) - self._tan[axis] * z) / self._norm[axis] <= r
        return inside | ~self._cullable

    def show(self, T_world_cam: NDArray[np.float64]) -> None:
        """Draw the geoms visible from ``T_world_cam`` only (the depth and ids pass)."""
        self._draw(self.visible(T_world_cam))

    def show_for_rgb(self) -> None:
        """After ``show`` of the same pose: keep its geoms when the RGB pass may cull, else draw all."""
        if not self._rgb_ok:
            self._draw(np.ones_like(self._shown))

    def _draw(self, want: NDArray[np.bool_]) -> None:
        for i in np.flatnonzero(want != self._shown).tolist():
            self._scene.geoms[i].dataid = int(self._dataid[i]) if want[i] else -1
        self._shown = want
