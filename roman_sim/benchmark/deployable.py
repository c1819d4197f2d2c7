"""The deployable operating point of a benchmark level: thresholds chosen on other worlds.

A deployed system runs one association threshold per method, for every heading, chosen
before it sees the world it runs in. Per level and method this module chooses it as
``benchmark.transfer`` does: leave one world (cell = scenario seed) out, choose on the
others the smallest ``k`` whose pooled precision over all headings of their cross-robot
pairs reaches the target, score the left-out world at that ``k``; pool the held-out
outcomes over the level's worlds. Per heading bin (and ``"all"``): held-out hits, false
positives and relevant pairs, recall with its pooled Wilson and its world-bootstrap
interval (worlds, then robot pairs within), precision with its world-bootstrap interval,
and whether that precision is within ``transfer.PRECISION_SLACK`` of the target. Methods
are ranked per bin by the world-bootstrap recall intervals (``benchmark.ranking``).

A level with a single world has no held-out figures: its entry says so.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from roman_sim.benchmark.board_records import Deployable, DeployableCell, HeldOutFigures
from roman_sim.benchmark.ranking import rank_by_intervals
from roman_sim.benchmark.transfer import HeldOutCell, PairOutcomes, held_out, held_out_cells, transfers
from roman_sim.evaluation.metrics import PairScore

log = logging.getLogger(__name__)

#: Default target precision of the deployable point.
DEFAULT_TARGET = 0.9
#: Bootstrap draws of the world intervals (fixed seed 0: the same pairs give the same bytes).
N_BOOT = 2000


def single_world_note(n_worlds: int) -> str:
    """The statement a level with fewer than two worlds carries instead of held-out figures."""
    return (
        f"held-out figures need at least two worlds (seeds) to choose a threshold on others; this level has {n_worlds}"
    )


def _world(s: PairScore) -> str:
    """The cell (world) a pooled pair came from: its name is ``<cell>:<robot>/<index>``."""
    return s.truth.a.split(":", 1)[0]


def outcomes(scores: Sequence[PairScore], method: str) -> tuple[PairOutcomes, np.ndarray]:
    """One method's cross-robot pairs as ``PairOutcomes`` (world = cell, cluster = robot pair), and headings."""
    rows = [s for s in scores if s.method == method and s.truth.kind == "inter"]
    o = PairOutcomes.from_lists(
        [_world(s) for s in rows],
        ["|".join(sorted((s.truth.robot_a, s.truth.robot_b))) for s in rows],
        [s.truth.relevant for s in rows],
        [s.correct for s in rows],
        [s.n_assoc for s in rows],
    )
    return o, np.asarray([s.truth.heading_diff_deg for s in rows], dtype=np.float64)


def _pair(ci: tuple[float, float] | None) -> list[float] | None:
    return None if ci is None else [float(ci[0]), float(ci[1])]


def held_out_figures(c: HeldOutCell, target: float) -> HeldOutFigures:
    """A held-out cell as ``leaderboard.json`` holds it, with whether its precision transfers."""
    return HeldOutFigures(
        hits=c.hits,
        false_positives=c.false_positives,
        n_relevant=c.n_relevant,
        recall=c.recall,
        recall_wilson=_pair(c.recall_wilson),
        recall_worlds=_pair(c.recall_worlds),
        precision=c.precision,
        precision_worlds=_pair(c.precision_worlds),
        transfers=transfers(c.precision, target),
    )


def _ranked(label: str, per_method: dict[str, HeldOutFigures]) -> DeployableCell:
    """One bin across methods: their held-out figures, ranks by world interval, widest half-width."""
    cis = {m: (None if c.recall_worlds is None else tuple(c.recall_worlds)) for m, c in per_method.items()}
    halves = [(ci[1] - ci[0]) / 2 for ci in cis.values() if ci is not None]
    ranks = rank_by_intervals(cis)  # type: ignore[arg-type]
    return DeployableCell(label, per_method, ranks, max(halves) if halves else None)


def deployable(
    scores: Sequence[PairScore],
    methods: Sequence[str],
    edges: Sequence[float],
    k_values: Sequence[int],
    target: float,
    level: float = 0.95,
) -> Deployable:
    """A level's deployable point as ``leaderboard.json`` holds it (see the module docstring)."""
    worlds = sorted({_world(s) for s in scores})
    if len(worlds) < 2:
        return Deployable(target, worlds, note=single_world_note(len(worlds)))
    thresholds: dict[str, dict[str, int | None]] = {}
    cells: dict[str, list[HeldOutFigures]] = {}
    labels: list[str] = []
    for m in methods:
        o, heading = outcomes(scores, m)
        if len(o.score) == 0:
            continue
        res = held_out(o, k_values, target)
        thresholds[m] = {w: t.k for w, t in res.thresholds.items()}
        got = held_out_cells(o, res.positive, heading, edges, N_BOOT, level, 0)
        labels = [c.label for c in got]
        cells[m] = [held_out_figures(c, target) for c in got]
        log.info("deployable %s: thresholds %s", m, thresholds[m])
    rows = [_ranked(lab, {m: cs[i] for m, cs in cells.items()}) for i, lab in enumerate(labels)]
    return Deployable(
        target,
        worlds,
        thresholds=thresholds,
        transfers={m: cs[-1].transfers for m, cs in cells.items()},
        bins=rows[:-1],
        overall=rows[-1] if rows else None,
    )
