"""Robot side of the visual method: keyframe selection, features + BoW, and attaching them to submaps.

A frame becomes a keyframe when the odometry has moved ``every_m`` or turned
``every_deg`` since the last keyframe, or ``every_s`` has passed (the first frame always
is one). The choice reads only times and odometry poses, so ``keyframe_mask`` knows the
keyframes before any image is rendered: a simulated robot renders RGB only for them.
Only robot data is used (RGB, depth, odometry), never truth. Each
keyframe belongs to the submap whose centre time is nearest, so the keyframes of a
robot are split between its submaps without overlap.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from roman_sim.align.visual.bow import BowVector
from roman_sim.align.visual.features import (
    DESCRIPTOR_BYTES,
    KeyframeFeatures,
    OrbParams,
    extract_features,
    make_orb,
)
from roman_sim.align.visual.vocabulary import Vocabulary
from roman_sim.core.config import StrictModel
from roman_sim.core.errors import MappingError
from roman_sim.core.geometry import inv_T, rotation_angle
from roman_sim.core.sensors import Frame
from roman_sim.mapping.types import KeyframeSet, Submap

log = logging.getLogger(__name__)


class KeyframeParams(StrictModel):
    """Keyframe selection and ORB settings."""

    every_m: float = Field(1.0, gt=0, description="new keyframe after this much odometry travel")
    every_deg: float = Field(15.0, gt=0, le=360, description="... or this much rotation")
    every_s: float = Field(5.0, gt=0, description="... or this much time")
    orb: OrbParams = Field(default_factory=OrbParams)


@dataclass
class Keyframe:
    """One keyframe: time, odometry camera pose, intrinsics (fx, fy, cx, cy), features, BoW vector."""

    t: float
    T_odom_cam: NDArray[np.float64]
    intrinsics: NDArray[np.float64]
    features: KeyframeFeatures
    bow: BowVector


class KeyframeExtractor:
    """Streams frames in, keeps the keyframes' features and BoW vectors (``offer`` per frame)."""

    def __init__(self, vocabulary: Vocabulary, params: KeyframeParams | None = None) -> None:
        self.vocabulary = vocabulary
        self.params = params or KeyframeParams()
        self._orb = make_orb(self.params.orb)
        self._last: tuple[float, NDArray[np.float64]] | None = None
        self.keyframes: list[Keyframe] = []

    def offer(self, frame: Frame) -> Keyframe | None:
        """Make ``frame`` a keyframe if it is due; returns it (or None).

        Raises: MappingError when a frame that is due has no RGB.
        """
        T = frame.T_odom_body
        if not keyframe_due(self._last, frame.t, T, self.params):
            return None
        if frame.rgb is None:
            raise MappingError(f"robot {frame.robot!r}: the visual method needs RGB frames (render_rgb: true)")
        self._last = (frame.t, np.array(T, dtype=np.float64))
        k = frame.intrinsics
        feats = extract_features(frame.rgb, frame.depth, k, self._orb, self.params.orb)
        kf = Keyframe(
            float(frame.t),
            frame.T_odom_cam,
            np.array([k.fx, k.fy, k.cx, k.cy]),
            feats,
            self.vocabulary.transform(feats.descriptors),
        )
        self.keyframes.append(kf)
        return kf

    def keyframe_set(self) -> KeyframeSet:
        """The keyframes so far, camera poses in the odometry frame."""
        return keyframe_set(self.keyframes, np.eye(4))


def keyframe_due(
    last: tuple[float, NDArray[np.float64]] | None, t: float, T: NDArray[np.float64], params: KeyframeParams
) -> bool:
    """Whether a frame at time ``t`` and odometry pose ``T`` is a keyframe after the keyframe ``last`` (t, pose)."""
    if last is None:
        return True
    t0, T0 = last
    moved = float(np.linalg.norm(T[:3, 3] - T0[:3, 3]))
    turned = np.degrees(rotation_angle(T0[:3, :3].T @ T[:3, :3]))
    return moved >= params.every_m or turned >= params.every_deg or t - t0 >= params.every_s - 1e-9


def keyframe_mask(
    t: NDArray[np.float64], T_odom_body: NDArray[np.float64], params: KeyframeParams | None = None
) -> NDArray[np.bool_]:
    """Which of the frames (times ``t``, odometry poses ``T_odom_body``) ``KeyframeExtractor`` keeps.

    The same decisions as offering every frame in order, made from the trajectory alone.
    """
    p = params or KeyframeParams()
    out = np.zeros(len(t), dtype=bool)
    last: tuple[float, NDArray[np.float64]] | None = None
    for i in range(len(t)):
        if keyframe_due(last, float(t[i]), T_odom_body[i], p):
            out[i] = True
            last = (float(t[i]), np.array(T_odom_body[i], dtype=np.float64))
    return out


def keyframe_set(keyframes: list[Keyframe], T_odom_submap: NDArray[np.float64]) -> KeyframeSet:
    """Pack keyframes into a ``KeyframeSet`` with camera poses in the submap frame."""
    T_sub_odom = inv_T(T_odom_submap)
    feats = [k.features for k in keyframes]
    bows = [k.bow for k in keyframes]

    def _cat(arrs: list[Any], shape: tuple[int, ...], dtype: Any) -> NDArray:
        return np.concatenate(arrs).astype(dtype) if arrs else np.zeros(shape, dtype)

    return KeyframeSet(
        t=np.array([k.t for k in keyframes], dtype=np.float64),
        T_submap_cam=np.array([T_sub_odom @ k.T_odom_cam for k in keyframes]).reshape(-1, 4, 4),
        intrinsics=np.array([k.intrinsics for k in keyframes], dtype=np.float64).reshape(-1, 4),
        bow_offsets=np.cumsum([0] + [len(b) for b in bows]).astype(np.int64),
        bow_words=_cat([b.words for b in bows], (0,), np.int32),
        bow_values=_cat([b.values for b in bows], (0,), np.float32),
        feat_offsets=np.cumsum([0] + [len(f) for f in feats]).astype(np.int64),
        uv=_cat([f.uv for f in feats], (0, 2), np.float32),
        descriptors=_cat([f.descriptors for f in feats], (0, DESCRIPTOR_BYTES), np.uint8),
        points=_cat([f.points for f in feats], (0, 3), np.float32),
    )


def select_keyframes(kf: KeyframeSet, idx: NDArray[np.int64], T_new_old: NDArray[np.float64]) -> KeyframeSet:
    """The keyframes ``idx`` of ``kf`` (in order), their camera poses re-expressed by ``T_new_old``."""
    idx = np.asarray(idx, dtype=np.int64)
    f = [np.arange(kf.feat_offsets[i], kf.feat_offsets[i + 1]) for i in idx]
    w = [np.arange(kf.bow_offsets[i], kf.bow_offsets[i + 1]) for i in idx]
    fi = np.concatenate(f).astype(np.int64) if f else np.zeros(0, np.int64)
    wi = np.concatenate(w).astype(np.int64) if w else np.zeros(0, np.int64)
    return KeyframeSet(
        t=kf.t[idx],
        T_submap_cam=np.einsum("ij,njk->nik", T_new_old, kf.T_submap_cam[idx]).reshape(-1, 4, 4),
        intrinsics=kf.intrinsics[idx],
        bow_offsets=np.cumsum([0] + [len(x) for x in w]).astype(np.int64),
        bow_words=kf.bow_words[wi],
        bow_values=kf.bow_values[wi],
        feat_offsets=np.cumsum([0] + [len(x) for x in f]).astype(np.int64),
        uv=kf.uv[fi],
        descriptors=kf.descriptors[fi],
        points=kf.points[fi],
    )


def attach_keyframes(submaps: list[Submap], keyframes: KeyframeSet | list[Keyframe]) -> list[Submap]:
    """Copies of one robot's ``submaps`` carrying its keyframes (each in the submap nearest in time).

    Args:
        submaps: the robot's submaps.
        keyframes: its keyframes, as ``Keyframe`` objects or a ``KeyframeSet`` whose poses are
            in the odometry frame (``KeyframeExtractor.keyframe_set()``).
    """
    kf = keyframe_set(keyframes, np.eye(4)) if isinstance(keyframes, list) else keyframes
    if not submaps:
        return []
    centre_t = np.array([s.t for s in submaps])
    owner = np.argmin(np.abs(centre_t[None, :] - kf.t[:, None]), axis=1) if len(kf) else np.zeros(0, np.int64)
    return [
        replace(s, keyframes=select_keyframes(kf, np.flatnonzero(owner == i), inv_T(s.T_odom_submap)))
        for i, s in enumerate(submaps)
    ]
