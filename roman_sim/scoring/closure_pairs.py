"""Loop closures matched to the submap pairs they estimate, as arrays.

``resolve`` matches each closure end ``(robot, t)`` to the robot's submap whose centre time
is nearest (ties: the lowest index) and decides, pair by pair, which closure the pair keeps:
the first of those with the highest score. The others, and closures whose two ends fall in
one submap or on a pair the evaluation does not score, are ``Unscored``, with the reason,
by their line in the closure file. All of it runs on the arrays of a ``ClosureSet`` (no
object per closure); the relative pose (``roman_sim.scoring.external``'s formula, body poses
from ``poses_at``) is computed only for the closures the pairs keep. ``poses_at`` and the
batched inverses do scipy's and ``inv_T``'s arithmetic, so the poses are those a closure-by-
closure loop gives, to the bit.
"""

from __future__ import annotations

from array import array
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from roman_sim.core.trajectory import Trajectory
from roman_sim.evaluation.pairs import select_pairs
from roman_sim.interop.closures import Closure, ClosureSet
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.scenario import Scenario

_EXACT_S = 1e-6  # a closure time this close to a frame's is that frame
_CHUNK = 1 << 14  # closure times matched to submap centres at a time


def pose_at(traj: Trajectory, t: float) -> NDArray[np.float64]:
    """The trajectory's pose at ``t``: a frame's own within 1 us, else interpolated (linear, slerp)."""
    return poses_at(traj, np.asarray([t], dtype=np.float64))[0]


def _nearest_frame(ts: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray[np.int64]:
    """For each of ``t``, the first index of the smallest ``|ts - t|`` (``ts`` non-decreasing, not empty)."""
    k = np.searchsorted(ts, t)  # the first frame at or after t
    right = np.minimum(k, len(ts) - 1)
    left = np.searchsorted(ts, ts[np.maximum(k - 1, 0)])  # the first frame of the time before t
    take_left = (k > 0) & ((k == len(ts)) | (np.abs(ts[left] - t) <= np.abs(ts[right] - t)))
    return np.where(take_left, left, right)


def poses_at(traj: Trajectory, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 4, 4) poses of the trajectory at times ``t`` (N,): a frame's own within 1 us, else interpolated
    between the frames around it (linear position, slerp rotation: scipy's ``Slerp`` arithmetic)."""
    t = np.asarray(t, dtype=np.float64)
    i = _nearest_frame(traj.t, t)
    out = traj.T[i].copy()
    if len(traj) == 1:
        return out
    between = np.abs(traj.t[i] - t) > _EXACT_S
    if not between.any():
        return out
    tb = t[between]
    j = np.clip(np.searchsorted(traj.t, tb), 1, len(traj) - 1)
    t0, t1 = traj.t[j - 1], traj.t[j]
    w = np.clip((tb - t0) / (t1 - t0), 0.0, 1.0)
    alpha = ((t0 + w * (t1 - t0)) - t0) / (t1 - t0)  # as Slerp computes it from the time it is given
    r0, r1 = Rotation.from_matrix(traj.T[j - 1, :3, :3]), Rotation.from_matrix(traj.T[j, :3, :3])
    rotvec = (r0.inv() * r1).as_rotvec()
    T = np.zeros((len(tb), 4, 4))
    T[:, :3, :3] = (r0 * Rotation.from_rotvec(rotvec * alpha[:, None])).as_matrix()
    T[:, :3, 3] = (1 - w)[:, None] * traj.T[j - 1, :3, 3] + w[:, None] * traj.T[j, :3, 3]
    T[:, 3, 3] = 1.0
    out[between] = T
    return out


def inv_Ts(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """``inv_T`` of each of (N, 4, 4) rigid transforms (the same arithmetic)."""
    Rt = np.swapaxes(T[:, :3, :3], 1, 2)
    out = np.zeros_like(T)
    out[:, :3, :3] = Rt
    out[:, :3, 3] = -(Rt @ T[:, :3, 3, None])[:, :, 0]
    out[:, 3, 3] = 1.0
    return out


def _nearest_submaps(subs: list[Submap], t: NDArray[np.float64]) -> NDArray[np.int64]:
    """For each of ``t``, the position in ``subs`` of the submap whose centre time is nearest (ties: the
    lowest index)."""
    order = sorted(range(len(subs)), key=lambda i: subs[i].index)
    centres = np.asarray([subs[i].t for i in order], dtype=np.float64)
    out = np.empty(len(t), dtype=np.int64)
    for s in range(0, len(t), _CHUNK):
        out[s : s + _CHUNK] = np.argmin(np.abs(centres[None, :] - t[s : s + _CHUNK, None]), axis=1)
    return np.asarray(order, dtype=np.int64)[out] if len(order) else out


class Unscored(Mapping[int, str]):
    """Why closures were not scored, by their line in the closure file (in line order).

    Held as two arrays and the distinct reasons, so a file of millions of unscored closures
    holds no object per closure.
    """

    def __init__(self, lines: NDArray[np.int64], codes: NDArray[np.int64], reasons: Sequence[str]) -> None:
        order = np.argsort(lines, kind="stable")
        self.lines, self.codes, self.reasons = lines[order], codes[order], list(reasons)

    def __len__(self) -> int:
        return len(self.lines)

    def __iter__(self) -> Iterator[int]:
        return (int(line) for line in self.lines)

    def __getitem__(self, line: int) -> str:
        i = int(np.searchsorted(self.lines, line))
        if i == len(self.lines) or self.lines[i] != line:
            raise KeyError(line)
        return self.reasons[int(self.codes[i])]

    @classmethod
    def of(cls, reasons: Mapping[int, str]) -> Unscored:
        """The same mapping held as arrays."""
        codes: dict[str, int] = {}
        lines = np.fromiter(reasons, dtype=np.int64, count=len(reasons))
        code = np.asarray([codes.setdefault(reasons[int(k)], len(codes)) for k in lines], dtype=np.int64)
        return cls(lines, code, list(codes))

    def items(self) -> Iterator[tuple[int, str]]:  # type: ignore[override]
        """``(line, reason)`` in line order, made one at a time."""
        return ((int(line), self.reasons[int(code)]) for line, code in zip(self.lines, self.codes))


@dataclass
class Resolved:
    """What ``resolve`` decided: each kept pair's ``(T_a_b, score, line)`` and the unscored closures."""

    pairs: dict[tuple[str, str], tuple[NDArray[np.float64], int, int]]  # (a, b) -> (T_a_b, n, line)
    unscored: Mapping[int, str]


@dataclass
class Matched:
    """Each closure's submap pair and the rows the pairs keep (``match``), before any pose is computed.

    Attributes:
        every: the submaps of all robots, in ``submaps`` order.
        ea, eb: (N,) each closure's two submaps (positions in ``every``).
        swap: (N,) whether the pair's order (robot, index) puts b's end first.
        keep: (K,) the rows the pairs keep, in file order.
        scores: (N,) each closure's score (the acceptance threshold where the file gives none).
        unscored: why every other row is not scored.
    """

    every: list[Submap]
    ea: NDArray[np.int64]
    eb: NDArray[np.int64]
    swap: NDArray[np.bool_]
    keep: NDArray[np.int64]
    scores: NDArray[np.int64]
    unscored: Unscored

    def pair(self, i: int) -> tuple[Submap, Submap]:
        """The submaps ``(a, b)`` of the ``i``-th kept row, in the pair's order."""
        row = int(self.keep[i])
        a, b = self.every[int(self.ea[row])], self.every[int(self.eb[row])]
        return (b, a) if self.swap[row] else (a, b)


def _ends(
    closures: ClosureSet, submaps: dict[str, list[Submap]], offset: dict[str, int]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Each closure's two submaps (positions in the submaps of all robots, in ``submaps`` order)."""
    ends = (np.empty(len(closures), dtype=np.int64), np.empty(len(closures), dtype=np.int64))
    for code, name in enumerate(closures.robots):
        for out, robot, t in zip(ends, (closures.robot_a, closures.robot_b), (closures.t_a, closures.t_b)):
            mine = robot == code
            if mine.any():
                out[mine] = offset[name] + _nearest_submaps(submaps[name], t[mine])
    return ends


def match(closures: ClosureSet, submaps: dict[str, list[Submap]], scenario: Scenario) -> Matched:
    """Each closure's submap pair, and the first closure of the highest score each evaluated pair keeps."""
    cs = closures
    every = [s for subs in submaps.values() for s in subs]
    offset = dict(zip(submaps, np.cumsum([0, *map(len, submaps.values())]).tolist()))
    gid = {s.name: i for i, s in enumerate(every)}
    rank = np.empty(len(every), dtype=np.int64)  # the (robot, index) order that orders a pair's two ends
    rank[sorted(range(len(every)), key=lambda i: (every[i].robot, every[i].index))] = np.arange(len(every))
    scored = {(gid[a.name], gid[b.name]) for a, b in select_pairs(every, scenario.evaluation).pairs}
    ea, eb = _ends(cs, submaps, offset)
    swap = rank[ea] > rank[eb]
    lo, hi = np.where(swap, eb, ea), np.where(swap, ea, eb)
    scores = np.where(cs.score < 0, scenario.posegraph.lc_association_thresh, cs.score)
    keep, unscored = _choose(lo, hi, scores, cs.line, [s.name for s in every], scored)
    return Matched(every, ea, eb, swap, keep, scores, unscored)


def estimates(
    closures: ClosureSet,
    m: Matched,
    odometry: dict[str, Trajectory],
    T_pa_pb: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """(K, 4, 4) ``T_a_b`` of the pairs ``m`` keeps, in the pair's order (``T_pa_pb``: the closures'
    relative poses, (N, 4, 4), when not the set's own)."""
    if not len(m.keep):
        return np.zeros((0, 4, 4))
    rel = closures.T_pa_pb if T_pa_pb is None else T_pa_pb
    T = _estimates(closures, rel, m.keep, m.every, m.ea, m.eb, odometry)
    flip = m.swap[m.keep]
    T[flip] = inv_Ts(T[flip])
    return T


def resolve(
    closures: ClosureSet | Sequence[Closure],
    submaps: dict[str, list[Submap]],
    odometry: dict[str, Trajectory],
    scenario: Scenario,
) -> Resolved:
    """Each closure as an estimate of one evaluated submap pair (see the module docstring).

    A pair keeps the first of its closures with the highest score. The pairs are decided on
    submap indices alone; the relative pose is computed for the closure each pair keeps.
    """
    cs = closures if isinstance(closures, ClosureSet) else ClosureSet.of(closures)
    m = match(cs, submaps, scenario)
    out = Resolved({}, m.unscored)
    for i, T in enumerate(estimates(cs, m, odometry)):
        a, b = m.pair(i)
        row = int(m.keep[i])
        out.pairs[(a.name, b.name)] = (T, int(m.scores[row]), int(cs.line[row]))
    return out


def _choose(
    lo: NDArray[np.int64],
    hi: NDArray[np.int64],
    scores: NDArray[np.int64],
    lines: NDArray[np.int64],
    names: list[str],
    scored: set[tuple[int, int]],
) -> tuple[NDArray[np.int64], Unscored]:
    """The rows each pair ``(lo, hi)`` keeps (in file order), and why every other row is not scored."""
    best: dict[tuple[int, int], tuple[int, int]] = {}  # pair -> the row it keeps and its score
    why: dict[str, int] = {}  # each distinct reason -> its code
    where, codes = array("q"), array("q")
    for row, (a, b, n, line) in enumerate(zip(lo.tolist(), hi.tolist(), scores.tolist(), lines.tolist())):
        key = (a, b)
        if a == b:
            reason = f"both ends fall in submap {names[a]}"
        elif key not in scored:
            reason = f"pair {names[a]}|{names[b]} is not scored by the evaluation (neighbours or capped)"
        elif key in best and best[key][1] >= n:
            reason = f"pair {names[a]}|{names[b]} already has a closure with a score >= {n}"
        else:
            if key in best:  # the row kept so far gives way
                gives_way = f"pair {names[a]}|{names[b]} has a closure with a higher score (line {line})"
                where.append(int(lines[best[key][0]]))
                codes.append(why.setdefault(gives_way, len(why)))
            best[key] = (row, n)
            continue
        where.append(line)
        codes.append(why.setdefault(reason, len(why)))
    keep = np.asarray(sorted(row for row, _ in best.values()), dtype=np.int64)
    return keep, Unscored(np.frombuffer(where, dtype=np.int64), np.frombuffer(codes, dtype=np.int64), list(why))


def _estimates(
    cs: ClosureSet,
    rel: NDArray[np.float64],
    rows: NDArray[np.int64],
    every: list[Submap],
    ea: NDArray[np.int64],
    eb: NDArray[np.int64],
    odometry: dict[str, Trajectory],
) -> NDArray[np.float64]:
    """``T_sa_sb`` of the closures ``rows``: ``inv(T_odom_sa) @ T_odom_body_a(t_a) @ T_pa_pb @
    inv(T_odom_body_b(t_b)) @ T_odom_sb``."""
    body = []
    for robot, t in ((cs.robot_a[rows], cs.t_a[rows]), (cs.robot_b[rows], cs.t_b[rows])):
        P = np.empty((len(rows), 4, 4))
        for code, name in enumerate(cs.robots):
            mine = robot == code
            if mine.any():
                P[mine] = poses_at(odometry[name], t[mine])
        body.append(P)
    Ta = np.stack([every[int(i)].T_odom_submap for i in ea[rows]]).astype(np.float64)
    Tb = np.stack([every[int(i)].T_odom_submap for i in eb[rows]]).astype(np.float64)
    return inv_Ts(Ta) @ body[0] @ rel[rows] @ inv_Ts(body[1]) @ Tb


__all__ = ["Matched", "Resolved", "Unscored", "estimates", "inv_Ts", "match", "pose_at", "poses_at", "resolve"]
