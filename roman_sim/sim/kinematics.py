"""Jackal-like kinematic ground robot on the terrain, and a pure-pursuit path follower.

The robot is a unicycle in the plane (x, y, heading) driven by (forward speed, yaw rate);
its 3D body pose (FLU) sits on the terrain: z = terrain height + body height, roll and
pitch from the terrain normal (the body z axis is the normal, x the heading projected on
the tangent plane). Both ``trajectory_along`` and ``GroundRobotEnv`` drive this class.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.geometry import make_T
from roman_sim.sim.paths import Path2D
from roman_sim.world.truth import Terrain

log = logging.getLogger(__name__)


@dataclass
class PlanarState:
    """Planar robot state: position (m) and heading (rad, about world z)."""

    x: float
    y: float
    heading: float


def integrate_unicycle(state: PlanarState, v: float, omega: float, dt: float) -> PlanarState:
    """Exact constant-(v, omega) arc integration over ``dt`` seconds."""
    h = state.heading
    if abs(omega) < 1e-9:
        dx, dy = v * dt * math.cos(h), v * dt * math.sin(h)
    else:
        h2 = h + omega * dt
        dx = v / omega * (math.sin(h2) - math.sin(h))
        dy = -v / omega * (math.cos(h2) - math.cos(h))
    return PlanarState(state.x + dx, state.y + dy, _wrap(h + omega * dt))


def _wrap(a: float) -> float:
    """``geometry.wrap_angle`` for one float (the follower calls it ten times per step)."""
    out = (a + math.pi) % (2 * math.pi) - math.pi
    return out + 2 * math.pi if out <= -math.pi else out


def body_pose_on_terrain(terrain: Terrain, state: PlanarState, body_height_m: float) -> NDArray[np.float64]:
    """4x4 ``T_world_body`` resting on the terrain at the planar state."""
    n = terrain.normal_at(state.x, state.y)
    f0 = np.array([np.cos(state.heading), np.sin(state.heading), 0.0])
    f = f0 - np.dot(f0, n) * n
    f /= np.linalg.norm(f)
    left = np.cross(n, f)
    z = float(terrain.height_at(state.x, state.y)) + body_height_m
    return make_T(np.column_stack([f, left, n]), [state.x, state.y, z])


class PathFollower:
    """Pure-pursuit controller: turns a ``Path2D`` into (forward speed, yaw rate) actions.

    Progress along the path is tracked monotonically, so paths that revisit places
    (loops, out-and-back) are followed in order.

    Args:
        path: the path to follow.
        speed_mps: cruise speed.
        lookahead_m: pure-pursuit look-ahead distance.
        max_yaw_rate: yaw-rate limit (rad/s).
        goal_tolerance_m: the run is done within this distance of the path end.
    """

    def __init__(
        self,
        path: Path2D,
        speed_mps: float = 1.0,
        lookahead_m: float = 0.4,
        max_yaw_rate: float = 1.5,
        goal_tolerance_m: float = 0.1,
    ) -> None:
        self.path = path
        self.speed = speed_mps
        self.lookahead = lookahead_m
        self.max_yaw_rate = max_yaw_rate
        self.tol = goal_tolerance_m
        self.progress_m = 0.0
        self.done = False

    def _update_progress(self, x: float, y: float) -> None:
        s = self.path.s
        lo = np.searchsorted(s, self.progress_m)
        hi = np.searchsorted(s, self.progress_m + max(2.0, 2 * self.lookahead))
        seg = self.path.xy[lo : hi + 1]
        if len(seg):
            i = int(np.argmin(np.sum((seg - [x, y]) ** 2, axis=1)))
            self.progress_m = float(s[lo + i])

    def act(self, x: float, y: float, heading: float) -> tuple[float, float]:
        """(forward speed m/s, yaw rate rad/s) for the current planar pose."""
        self._update_progress(x, y)
        end = self.path.xy[-1]
        remaining = self.path.length - self.progress_m
        if remaining <= self.tol and float(np.hypot(end[0] - x, end[1] - y)) <= self.tol + 0.05:
            self.done = True
            return 0.0, 0.0
        tx, ty, _ = self.path.at(self.progress_m + self.lookahead)
        alpha = _wrap(float(np.arctan2(ty - y, tx - x)) - heading)
        if math.cos(alpha) < 0.0:  # target behind (U-turn, sharp corner): turn on the spot
            return 0.0, math.copysign(self.max_yaw_rate, alpha if alpha != 0.0 else 1.0)
        dist = max(float(np.hypot(tx - x, ty - y)), 1e-6)
        k = 2.0 * math.sin(alpha) / dist  # pure-pursuit curvature
        v = self.speed * max(0.2, math.cos(alpha))
        if abs(k) * v > self.max_yaw_rate:  # slow down instead of overshooting sharp turns
            v = self.max_yaw_rate / abs(k)
        return float(v), float(v * k)
