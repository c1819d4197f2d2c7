"""How many worlds a level needs: a suite's power plan, read from a pilot board.

Every paired verdict of a board (``board_records.PairVerdict``) states, besides its own test, the
worlds that a paired difference of ``paired_worlds.EFFECT`` (0.05) of held-out recall needs to be
detected with power ``paired_worlds.POWER`` (0.8) at the spread of the per-world differences the
board measured (``paired_worlds.worlds_for``: the world-clustered standard error scaled by the
square root of the worlds). A pilot is a board run with few worlds per level; its plan for a level
is the largest of those counts over the level's heading bins (and the level over every heading)
and method pairs, leaving out pairs with a method below the floor (``too few hits``: no spread to
plan with; of equal counts the first in the board's order). The pair and bin that set it are
kept, so a suite can say what it gives up when it runs fewer worlds.

A suite states its plan (``suites.PowerPlan``: the worlds per level and the pilot they come from);
a level planned with fewer worlds than its plan is refused when the suite is read.

``planned_worlds`` carries a pilot's plan to other levels and another effect: a level's worlds
for 0.05 interpolated linearly in the measured ambiguity index between the two pilot levels
around it (the nearest pilot level outside their range), scaled by ``(0.05 / effect)^2`` (the
standard error falls as one over the square root of the worlds), rounded up, and at least
``least``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from roman_sim.benchmark.board_records import Leaderboard
from roman_sim.evaluation.paired_worlds import EFFECT


@dataclass(frozen=True)
class LevelPower:
    """A level's power plan from a pilot: the worlds needed and the comparison that needs them.

    Attributes:
        worlds: worlds the comparison below needs (``PairVerdict.worlds_for_power``).
        heading: the heading bin (or ``all``) of that comparison.
        a, b: the two methods compared.
        pilot_worlds: the worlds the pilot ran at the level.
    """

    worlds: int
    heading: str
    a: str
    b: str
    pilot_worlds: int


def pilot_plan(board: Leaderboard) -> dict[str, LevelPower]:
    """Per level of ``board`` with paired verdicts: the most worlds any of its verdicts needs for power.

    A level without a deployable point or without a verdict above the floor has no plan (left out).
    """
    out: dict[str, LevelPower] = {}
    for level in board.levels:
        dep = level.deployable
        if dep is None:
            continue
        best: LevelPower | None = None
        for cell in dep.cells():
            for v in cell.verdicts:
                if v.verdict == "too few hits":
                    continue
                if best is None or v.worlds_for_power > best.worlds:
                    best = LevelPower(v.worlds_for_power, cell.heading, v.a, v.b, len(dep.worlds))
        if best is not None:
            out[level.name] = best
    return out


def planned_worlds(board: Leaderboard, targets: dict[str, float], effect: float, least: int = 2) -> dict[str, int]:
    """Per level of ``targets`` (name -> the ambiguity index it is placed at): the worlds ``board``, read as a
    pilot, says a paired difference of ``effect`` needs (see the module docstring).

    Raises:
        ValueError: a pilot without a plan at two levels with a measured index, or an effect outside (0, 1].
    """
    if not 0.0 < effect <= 1.0:
        raise ValueError(f"effect: a difference of recall in (0, 1], got {effect}")
    plan = pilot_plan(board)
    at = sorted(
        (e.ambiguity_index, plan[e.name].worlds)
        for e in board.levels
        if e.name in plan and e.ambiguity_index is not None
    )
    if len(at) < 2:
        raise ValueError("the pilot plans fewer than two levels with a measured ambiguity index")
    xs, ys = [x for x, _ in at], [float(y) for _, y in at]
    scale = (EFFECT / effect) ** 2
    out = {}
    for level, index in targets.items():
        if index <= xs[0]:
            need = ys[0]
        elif index >= xs[-1]:
            need = ys[-1]
        else:
            i = next(j for j in range(1, len(xs)) if index <= xs[j])
            need = ys[i - 1] + (ys[i] - ys[i - 1]) * (index - xs[i - 1]) / (xs[i] - xs[i - 1])
        out[level] = max(least, math.ceil(need * scale - 1e-9))
    return out


__all__ = ["LevelPower", "pilot_plan", "planned_worlds"]
