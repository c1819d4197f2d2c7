"""Choosing a method's setting on calibration worlds, and what it gives on held-out worlds.

A *config* is a setting of everything but the association threshold (an aligner's
parameters, the submap gating); a *setting* is a config and a threshold. Per config the
outcomes of every world's cross-robot pairs are one ``PairOutcomes`` (``transfer``), with
each pair's alignment time (a pair gated out costs 0) and each world's driven kilometres.

- ``choose_setting``: on calibration worlds only, per config the smallest threshold that
  qualifies under the rule; among the configs with one, the highest pooled recall, then the
  fewest false loop closures per km, then the least time per pair, then the config's order.
  Rule ``point`` (these functions' default; ``roman-sim tune`` takes ``world``): the
  threshold's pooled precision reaches the target (``transfer.choose_threshold``). Rule
  ``lower``: the lower end of the setting's precision interval for one new world reaches the
  target (``setting_new_world``: each calibration world's Wilson interval at that fixed
  setting and the pooled world-bootstrap interval, the hull; the same statement the tune makes
  of its choice). Under ``lower`` a setting whose
  point precision reaches the target but whose worlds could fall below it does not qualify;
  when none qualifies nothing is chosen (never the point rule's choice instead). Rule ``world``:
  the beta-binomial spread of the worlds' precisions at that setting (``world_spread``) puts at
  least ``WORLD_SHARE`` of new worlds within ``transfer.PRECISION_SLACK`` of the target. The
  pooled precision weighs worlds by their accepted pairs, so a few busy, clean worlds carry a
  threshold at which many small worlds fall short; this rule asks what one new world gives, and
  unlike ``lower`` it does not add each world's own sampling noise of few pairs to the spread.
- ``nested_held_out``: leave-one-world-out: each world is scored at the setting chosen on
  the other worlds only; the pooled held-out recall and precision with world-bootstrap
  intervals are what the tuning procedure gives over as many worlds it has not seen; each
  world's own held-out precision, and the hull of their Wilson intervals and the pooled
  interval (``transfer.new_world_interval``), what it gives in *one* such world.
- ``config_rows``: per config, its threshold chosen on the other worlds
  (``transfer.held_out``), held-out recall and precision with world-bootstrap intervals,
  false loop closures per km and time per pair; ``pareto`` marks the configs no other beats
  in all three of recall, false closures per km and time.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from roman_sim.benchmark.transfer import (
    PRECISION_SLACK,
    HeldOutCell,
    PairOutcomes,
    Threshold,
    WorldPrecision,
    check_target,
    choose_threshold,
    counts,
    held_out,
    held_out_cell,
    new_world_interval,
    positives,
    transfers,
    world_bootstrap,
    world_precisions,
)
from roman_sim.benchmark.world_spread import WorldSpread, fit_spread
from roman_sim.core.errors import ConfigError

log = logging.getLogger(__name__)

#: The recommendation rules: ``point`` (pooled precision reaches the target), ``lower`` (the lower
#: end of the one-new-world precision interval reaches it) and ``world`` (the worlds' spread puts
#: ``WORLD_SHARE`` of new worlds within the slack of the target); see the module docstring.
RULES = ("point", "lower", "world")

#: Under rule ``world``, the share of new worlds whose precision must be within the slack of the target.
WORLD_SHARE = 0.9


def check_rule(rule: str) -> str:
    """``rule`` when it is one of ``RULES`` (ConfigError naming ``--rule`` and the allowed values otherwise)."""
    if rule not in RULES:
        raise ConfigError(f"--rule: expected one of {', '.join(RULES)}, got {rule!r}")
    return rule


def setting_new_world(o: PairOutcomes, k: int, n_boot: int = 2000, seed: int = 0) -> tuple[float, float] | None:
    """The one-new-world precision interval of threshold ``k`` fixed over the worlds of ``o``: the hull of
    each world's Wilson interval and the pooled world-bootstrap interval (None: nothing accepted)."""
    pos = positives(o, k)
    return _new_world(o, pos, world_precisions(o, pos), n_boot, seed)


def _new_world(
    o: PairOutcomes, pos: NDArray[np.bool_], per_world: list[WorldPrecision], n_boot: int, seed: int
) -> tuple[float, float] | None:
    """The hull of ``per_world``'s Wilson intervals and the pooled world-bootstrap interval at ``pos``."""
    if all(p.wilson is None for p in per_world):
        return None
    return new_world_interval(per_world, world_bootstrap(o, pos, "precision", n_boot, 0.95, seed))


def lower_threshold(
    o: PairOutcomes, k_values: Sequence[int], target: float, n_boot: int = 2000, seed: int = 0
) -> Threshold:
    """The smallest ``k`` of ``k_values`` whose one-new-world interval on ``o`` (``setting_new_world``) has its
    lower end at or above ``target``; ``Threshold(None, 0, 0)`` when none has."""
    t = float(check_target(target))
    for k in sorted(int(x) for x in k_values):
        pos = positives(o, k)
        per_world = world_precisions(o, pos)
        # the hull's lower end is at most any world's: the bootstrap only when every world clears the target
        if any(p.wilson is None or p.wilson[0] < t for p in per_world):
            continue
        iv = _new_world(o, pos, per_world, n_boot, seed)
        if iv is not None and iv[0] >= t:
            tp, fp, _ = counts(o, pos)
            return Threshold(k, tp, fp)
    return Threshold(None, 0, 0)


def setting_spread(o: PairOutcomes, k: int) -> WorldSpread | None:
    """The beta-binomial spread (``world_spread.fit_spread``) of the worlds' precisions at threshold ``k`` fixed
    over the worlds of ``o`` (None: fewer than two worlds accepted a pair)."""
    per_world = world_precisions(o, positives(o, k))
    return fit_spread([p.hits for p in per_world], [p.hits + p.false_positives for p in per_world])


def world_threshold(o: PairOutcomes, k_values: Sequence[int], target: float) -> Threshold:
    """The smallest ``k`` of ``k_values`` whose spread over the worlds of ``o`` (``setting_spread``) puts at least
    ``WORLD_SHARE`` of new worlds at a precision of ``target - PRECISION_SLACK`` or more; ``Threshold(None, 0, 0)``
    when none does."""
    t = float(check_target(target))
    for k in sorted(int(x) for x in k_values):
        fit = setting_spread(o, k)
        if fit is not None and fit.share(t - PRECISION_SLACK) >= WORLD_SHARE:
            tp, fp, _ = counts(o, positives(o, k))
            return Threshold(k, tp, fp)
    return Threshold(None, 0, 0)


@dataclass(frozen=True)
class ConfigOutcomes:
    """One config's cross-robot pairs over every world.

    Attributes:
        pairs: the outcomes (world, robot pair, relevant, correct, associations).
        runtime_s: (n,) alignment time of each pair (0 for a pair gating skipped; NaN: unknown).
    """

    pairs: PairOutcomes
    runtime_s: NDArray[np.float64]


@dataclass(frozen=True)
class Setting:
    """A config (by id) and a threshold, with its pooled figures on the worlds it was chosen on."""

    config: str
    k: int
    recall: float
    false_per_km: float
    time_per_pair_s: float | None


def _time(c: ConfigOutcomes, mask: NDArray[np.bool_]) -> float | None:
    r = c.runtime_s[mask]
    r = r[np.isfinite(r)]
    return float(r.mean()) if len(r) else None


def _km(km: Mapping[str, float], worlds: Sequence[str]) -> float:
    return float(sum(km[w] for w in worlds))


def choose_setting(
    configs: Mapping[str, ConfigOutcomes],
    km: Mapping[str, float],
    worlds: Sequence[str],
    k_values: Sequence[int],
    target: float,
    rule: str = "point",
    n_boot: int = 2000,
    seed: int = 0,
) -> Setting | None:
    """The setting chosen on ``worlds`` only under ``rule`` (see the module docstring); None when no setting
    qualifies."""
    check_rule(rule)
    best: tuple[tuple[float, float, float, int], Setting] | None = None
    total_km = _km(km, worlds)
    for i, (cid, c) in enumerate(configs.items()):
        mask = np.isin(c.pairs.world, np.asarray(worlds, dtype=np.str_))
        o = c.pairs.subset(mask)
        if rule == "lower":
            th = lower_threshold(o, k_values, target, n_boot, seed)
        elif rule == "world":
            th = world_threshold(o, k_values, target)
        else:
            th = choose_threshold(o, k_values, target)
        if th.k is None:
            continue
        rel = int(np.count_nonzero(o.relevant))
        recall = th.tp / rel if rel else 0.0
        fpk = th.fp / total_km if total_km > 0 else float(th.fp)
        t = _time(c, mask)
        s = Setting(cid, int(th.k), recall, fpk, t)  # the association sweep: whole thresholds
        key = (-recall, fpk, t if t is not None else float("inf"), i)
        if best is None or key < best[0]:
            best = (key, s)
    return None if best is None else best[1]


@dataclass(frozen=True)
class Figures:
    """Held-out counts and ratios with their intervals (``transfer.HeldOutCell``, label ``"all"``), the false
    loop closures per km and whether the precision is within ``transfer.PRECISION_SLACK`` of the target."""

    cell: HeldOutCell
    false_per_km: float
    transfers: bool


def figures(o: PairOutcomes, positive: NDArray[np.bool_], km: float, target: float, n_boot: int, seed: int) -> Figures:
    """``Figures`` of ``positive`` over ``o`` (``km``: the worlds' driven kilometres)."""
    c = held_out_cell("all", o, positive, n_boot, 0.95, seed)
    fp = c.false_positives
    return Figures(c, fp / km if km > 0 else float(fp), transfers(c.precision, target))


@dataclass(frozen=True)
class Evidence:
    """What a choice is made from: each config's outcomes, each world's kilometres, the thresholds
    tried, the target precision, the bootstrap's draws and seed, and the rule of the choice."""

    configs: Mapping[str, ConfigOutcomes]
    km: Mapping[str, float]
    k_values: Sequence[int]
    target: float
    n_boot: int = 2000
    seed: int = 0
    rule: str = "point"


@dataclass(frozen=True)
class NestedHeldOut:
    """Leave-one-world-out of the whole choice.

    Attributes:
        chosen: per world the setting chosen on the others (None: none reached the target).
        figures: the pooled held-out figures.
        per_world: each world's precision at its setting (``transfer.world_precisions``).
        new_world: the precision interval of one new world (``transfer.new_world_interval``).
    """

    chosen: dict[str, Setting | None]
    figures: Figures
    per_world: list[WorldPrecision]
    new_world: tuple[float, float] | None


def _worlds(configs: Mapping[str, ConfigOutcomes]) -> list[str]:
    if not configs:
        raise ConfigError("tune: no config to choose from")
    worlds = next(iter(configs.values())).pairs.worlds()
    if len(worlds) < 2:
        raise ConfigError(f"worlds: need at least two to split into calibration and held-out, got {len(worlds)}")
    return worlds


def nested_held_out(ev: Evidence) -> NestedHeldOut:
    """Each world scored at the setting chosen on the other worlds (``choose_setting``), pooled."""
    check_target(ev.target)
    configs, km = ev.configs, ev.km
    worlds = _worlds(configs)
    first = next(iter(configs.values())).pairs
    parts: list[PairOutcomes] = []
    pos: list[NDArray[np.bool_]] = []
    chosen: dict[str, Setting | None] = {}
    for w in worlds:
        s = choose_setting(
            configs, km, [x for x in worlds if x != w], ev.k_values, ev.target, ev.rule, ev.n_boot, ev.seed
        )
        chosen[w] = s
        src = configs[s.config].pairs if s is not None else first
        own = src.subset(src.world == w)
        parts.append(own)
        pos.append(positives(own, s.k if s is not None else None))
        log.debug("world %s: setting %s chosen on the other %d worlds", w, s, len(worlds) - 1)
    o = PairOutcomes(
        np.concatenate([p.world for p in parts]),
        np.concatenate([p.cluster for p in parts]),
        np.concatenate([p.relevant for p in parts]),
        np.concatenate([p.correct for p in parts]),
        np.concatenate([p.score for p in parts]),
    )
    positive = np.concatenate(pos)
    f = figures(o, positive, _km(km, worlds), ev.target, ev.n_boot, ev.seed)
    per_world = world_precisions(o, positive)
    return NestedHeldOut(chosen, f, per_world, new_world_interval(per_world, f.cell.precision_worlds))


@dataclass(frozen=True)
class ConfigRow:
    """One config at thresholds chosen on other worlds: held-out figures, time per pair, front membership."""

    config: str
    thresholds: dict[str, int | None]
    figures: Figures
    time_per_pair_s: float | None
    on_front: bool = False


def config_rows(ev: Evidence) -> list[ConfigRow]:
    """Per config (in order) its held-out row; ``on_front`` set by ``pareto``."""
    worlds = _worlds(ev.configs)
    rows = []
    for cid, c in ev.configs.items():
        res = held_out(c.pairs, ev.k_values, ev.target)
        f = figures(c.pairs, res.positive, _km(ev.km, worlds), ev.target, ev.n_boot, ev.seed)
        all_pairs = np.ones(len(c.runtime_s), dtype=np.bool_)
        ks = {w: None if t.k is None else int(t.k) for w, t in res.thresholds.items()}
        rows.append(ConfigRow(cid, ks, f, _time(c, all_pairs)))
    return pareto(rows)


def pareto(rows: list[ConfigRow]) -> list[ConfigRow]:
    """``rows`` with ``on_front`` set: no other row has at least the recall, at most the false closures
    per km and at most the time per pair, and is better in one of them (rows without recall are off it)."""

    def objectives(r: ConfigRow) -> tuple[float, float, float] | None:
        if r.figures.cell.recall is None:
            return None
        t = r.time_per_pair_s if r.time_per_pair_s is not None else float("inf")
        return (-r.figures.cell.recall, r.figures.false_per_km, t)

    obj = [objectives(r) for r in rows]
    out = []
    for i, r in enumerate(rows):
        a = obj[i]
        dominated = a is None or any(
            b is not None and all(x <= y for x, y in zip(b, a, strict=True)) and b != a for b in obj
        )
        out.append(ConfigRow(r.config, r.thresholds, r.figures, r.time_per_pair_s, not dominated))
    return out
