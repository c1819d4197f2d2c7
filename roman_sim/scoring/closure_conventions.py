"""The conventions of a closure file, checked against the truth.

A closure file can follow another convention than the one it is read with, and then scores
as wrong closures without any error: its quaternions written w first (``qw qx qy qz``), its
edges inverted (``T_b_a`` given for ``T_a_b``), or its two robots swapped (robot ``a``'s
stamps given as ``b``'s). ``check`` scores the file under every combination of the three
(the quaternion order, inverted or not, swapped or not: eight, four when the run has not
exactly two robots) against the run's truth: how many of the submap pairs the closures
estimate are correct (the evaluation's rotation and translation tolerances). It takes the
closure table and the submaps' true poses only, never a run.

A combination scores *far better* than another when it has at least ``FAR_FACTOR`` times
as many correct pairs and at least ``FAR_GAIN`` more. ``ConventionCheck.verdict`` then says,
in one line, which flags would apply it (``--quaternion-order wxyz``, ``--invert-edges``,
``--swap-robots``), or, when a flag the user gave is what makes the file score worse, that
it is an error.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.geometry import inv_T, pose_error
from roman_sim.core.trajectory import Trajectory
from roman_sim.evaluation.metrics import is_correct
from roman_sim.interop.closures import QUATERNION_ORDERS, ClosureSet, QuaternionOrder
from roman_sim.interop.stamps import matched
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.scenario import Scenario
from roman_sim.scoring.closure_pairs import estimates, inv_Ts, match

#: A convention scores far better with at least this many times the correct pairs ...
FAR_FACTOR = 2
#: ... and at least this many more.
FAR_GAIN = 3


@dataclass(frozen=True)
class Convention:
    """How a closure file is read.

    Attributes:
        quaternion_order: the order of its four quaternion numbers.
        invert_edges: its relative poses are ``T_b_a`` (taken as ``inv``).
        swap_robots: its two robots' names are exchanged.
    """

    quaternion_order: QuaternionOrder = "xyzw"
    invert_edges: bool = False
    swap_robots: bool = False

    def flags(self) -> list[str]:
        """The command-line flags that select it (none for the default)."""
        out = [] if self.quaternion_order == "xyzw" else [f"--quaternion-order {self.quaternion_order}"]
        return out + ["--invert-edges"] * self.invert_edges + ["--swap-robots"] * self.swap_robots

    def describe(self) -> str:
        """``as read`` for the default, else ``with`` and its flags."""
        return f"with {' '.join(self.flags())}" if self.flags() else "as read"


def reorder(T: NDArray[np.float64], read: QuaternionOrder, wanted: QuaternionOrder) -> NDArray[np.float64]:
    """(N, 4, 4) poses whose rotations were read from quaternions in order ``read``, read in order ``wanted``."""
    if read == wanted:
        return T
    q = Rotation.from_matrix(T[:, :3, :3]).as_quat()  # the four numbers as ``read`` placed them, up to sign
    numbers = q if read == "xyzw" else q[:, [3, 0, 1, 2]]  # back to the file's order
    xyzw = numbers if wanted == "xyzw" else numbers[:, [1, 2, 3, 0]]
    out = T.copy()
    out[:, :3, :3] = Rotation.from_quat(xyzw).as_matrix()
    return out


def swapped(cs: ClosureSet, robots: list[str]) -> ClosureSet:
    """``cs`` with the run's two robots exchanged (``robots``: the run's two robot names)."""
    a, b = robots
    names = tuple(b if r == a else a if r == b else r for r in cs.robots)
    return replace(cs, robots=names)


def subset(cs: ClosureSet, keep: NDArray[np.bool_]) -> ClosureSet:
    """The closures of ``cs`` where ``keep``."""
    return ClosureSet(
        cs.robots,
        cs.robot_a[keep],
        cs.t_a[keep],
        cs.robot_b[keep],
        cs.t_b[keep],
        cs.T_pa_pb[keep],
        cs.score[keep],
        cs.line[keep],
        cs.files,
    )


def on_frames(cs: ClosureSet, frames: dict[str, NDArray[np.float64]]) -> NDArray[np.bool_]:
    """Whether both ends of each closure name a robot of the run and match one of its frames."""
    ok = np.ones(len(cs), dtype=bool)
    for code, name in enumerate(cs.robots):
        for robot, t in ((cs.robot_a, cs.t_a), (cs.robot_b, cs.t_b)):
            mine = robot == code
            if mine.any():
                ok[mine] &= matched(frames[name], t[mine]) if name in frames else False
    return ok


def apply(cs: ClosureSet, conv: Convention, robots: list[str]) -> ClosureSet:
    """A set read with ``conv``'s quaternion order, turned to ``conv``: edges inverted, robots swapped."""
    out = replace(cs, T_pa_pb=inv_Ts(cs.T_pa_pb)) if conv.invert_edges else cs
    return swapped(out, robots) if conv.swap_robots else out


@dataclass
class ConventionCheck:
    """Correct pairs of a closure file under each convention tried.

    Attributes:
        chosen: the convention the file is scored with.
        correct: convention -> submap pairs estimated correctly.
        estimated: convention -> submap pairs estimated.
    """

    chosen: Convention
    correct: dict[Convention, int] = field(default_factory=dict)
    estimated: dict[Convention, int] = field(default_factory=dict)

    def best(self) -> Convention:
        """The convention with the most correct pairs (ties: the chosen one, then the fewest flags)."""
        return max(self.correct, key=lambda c: (self.correct[c], c == self.chosen, -len(c.flags())))

    def far_better(self, a: Convention, b: Convention) -> bool:
        """Whether ``a`` scores far better than ``b`` (module docstring)."""
        ca, cb = self.correct[a], self.correct[b]
        return ca >= FAR_FACTOR * cb and ca >= cb + FAR_GAIN

    def _count(self, c: Convention) -> str:
        return f"{self.correct[c]} of {self.estimated[c]} estimated pairs correct {c.describe()}"

    def verdict(self, path: str | Path, given: list[str]) -> tuple[str | None, str | None]:
        """``(error, warning)``: one line each, None when there is none.

        An error when a flag in ``given`` (the flags the user gave) is one the far better
        convention does not have; a warning naming the flags to add otherwise.
        """
        best = self.best()
        if best == self.chosen or not self.far_better(best, self.chosen):
            return None, None
        have, want = self.chosen.flags(), best.flags()
        drop = [f for f in have if f not in want and any(f.startswith(g) for g in given)]
        add = [f for f in want if f not in have]
        if drop:
            todo = f"drop {' '.join(drop)}" + (f", add {' '.join(add)}" if add else "")
            return (
                f"{' '.join(drop)} make{'s' if len(drop) == 1 else ''} {path} score worse: "
                f"{self._count(self.chosen)}, {self._count(best)} ({todo})",
                None,
            )
        why = "; ".join(_reason(self.chosen, best))
        return None, (
            f"{path} scores far better under another convention: {self._count(best)}, {self._count(self.chosen)} "
            f"({why}); scored {self.chosen.describe()}, rerun with {' '.join(add)} to apply it"
        )


def _reason(chosen: Convention, best: Convention) -> list[str]:
    out = []
    if best.quaternion_order != chosen.quaternion_order:
        first = "w" if best.quaternion_order == "wxyz" else "x"
        out.append(f"its quaternions look {first}-first, {' '.join('q' + c for c in best.quaternion_order)}")
    if best.invert_edges != chosen.invert_edges:
        out.append("its edges look inverted, T_b_a for T_a_b")
    if best.swap_robots != chosen.swap_robots:
        out.append("its two robots look swapped")
    return out


def _n_correct(T: NDArray[np.float64], pairs: list[tuple[Submap, Submap]], scenario: Scenario) -> int:
    n = 0
    for est, (a, b) in zip(T, pairs):
        if a.truth is None or b.truth is None:
            continue
        rot, trans = pose_error(est, inv_T(a.truth.T_world_submap) @ b.truth.T_world_submap)
        n += is_correct(math.degrees(rot), trans, scenario.evaluation)
    return n


def check(
    read: ClosureSet,
    chosen: Convention,
    frames: dict[str, NDArray[np.float64]],
    submaps: dict[str, list[Submap]],
    odometry: dict[str, Trajectory],
    scenario: Scenario,
) -> ConventionCheck:
    """Score the closures ``read`` (with ``chosen``'s quaternion order, before its other changes) under
    every convention; closures whose ends match no frame under one are left out of its count."""
    robots = list(submaps)
    out = ConventionCheck(chosen)
    for swap in (False, True) if len(robots) == 2 else (False,):
        base = apply(read, Convention(swap_robots=swap), robots)
        kept = subset(base, on_frames(base, frames))
        m = match(kept, submaps, scenario)
        pairs = [m.pair(i) for i in range(len(m.keep))]
        for order, invert in itertools.product(QUATERNION_ORDERS, (False, True)):
            conv = Convention(order, invert, swap)
            T = reorder(kept.T_pa_pb, chosen.quaternion_order, order)
            T = inv_Ts(T) if invert else T
            out.correct[conv] = _n_correct(estimates(kept, m, odometry, T), pairs, scenario)
            out.estimated[conv] = len(pairs)
    return out
