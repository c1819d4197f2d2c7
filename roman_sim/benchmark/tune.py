"""``roman-sim tune``: a method's declared parameters tuned for a target precision, over worlds.

The source is a scenario (its worlds are the seeds given), a sweep (each of its runs is a
world) or a benchmark suite (each (level, seed) cell is a world; with a level, only that
level's cells: calibration and held-out worlds then share one ambiguity level, as the
leaderboard's thresholds, chosen per method and level, do). The job

1. checks everything that can be checked before any work (target, parameters and their
   ranges, the level, at least two worlds; ``tune_space``);
2. per world and aligner parameter set, runs the world's scenario with the method alone,
   without gating or pose graph, into ``work/<world>/<alignment>/`` (the shared stage cache,
   or the folder's own ``cache/`` when that is off, hands the maps of a world to every
   alignment of it: a new alignment re-aligns, never re-maps; a benchmark's cells hand theirs
   to a tune of the same suite), and keeps the pairs' outcomes and times
   (``outcomes.json``) under the run's key (``Experiment.run_key``: its stages' resolved
   parameters and code); a finished alignment is not run again while that key holds;
3. applies each gating setting to those ungated results (``align.gating.gate_pairs`` on the
   world's submaps; a gated-out pair is "no alignment" and costs no time), and each threshold
   by the pairs' association counts: neither re-maps nor re-aligns;
4. scores with ``benchmark.tune_choice``: per config (aligner x gating setting) held-out recall
   and precision with world-bootstrap intervals at thresholds chosen on the other worlds,
   false loop closures per km and time per pair, the Pareto front; the recommended setting
   (chosen on every world of the source) with the held-out figures of the same choice made
   leaving each world out, pooled and per world, and the precision interval of one new world,
   and how the recommended setting's precision spreads over the worlds (a beta-binomial fit:
   the share of new worlds at the target);
5. writes ``tune.json``, ``front.png`` and ``recommended.yaml`` (scenario sections: paste
   them into a scenario or pass the file as ``roman-sim run ... --set @recommended.yaml``).

Interrupted, the job resumes where it stopped: finished alignments are read back, an
interrupted one continues from its run folder's checkpoints.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from roman_sim.benchmark.board_records import HeldOutFigures
from roman_sim.benchmark.transfer import PRECISION_SLACK, HeldOutCell, PairOutcomes, check_target, transfers
from roman_sim.benchmark.tune_choice import (
    ConfigOutcomes,
    Evidence,
    Figures,
    check_rule,
    choose_setting,
    config_rows,
    nested_held_out,
    setting_spread,
)
from roman_sim.benchmark.tune_result import (
    TuneChoice,
    TuneConfig,
    TuneHeldOut,
    TuneRecommended,
    TuneResult,
    TuneSpread,
    TuneWorldHeldOut,
    TuneWorldKm,
    write_tune,
)
from roman_sim.benchmark.tune_space import THRESHOLD, Config, Grid, build_grid, parse_params
from roman_sim.core.atomic import write_text
from roman_sim.core.config import read_yaml, stable_hash, validate_model
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.records import OMIT_NONE, RecordError, read_record, write_record
from roman_sim.evaluation.records import RunTimings
from roman_sim.pipeline.scenario import Scenario
from roman_sim.runner.executors import Executor, ExecutorConfig, open_executor

log = logging.getLogger(__name__)
T = TypeVar("T")

TUNE_JSON = "tune.json"
JOB_JSON = "job.json"
RECOMMENDED_YAML = "recommended.yaml"
FRONT_PNG = "front.png"
OUTCOMES_JSON = "outcomes.json"
WORLD_JSON = "world.json"
WORK_DIR = "work"
CACHE_DIR = "cache"
#: Bootstrap draws of the world intervals (seed 0: the same outcomes give the same bytes).
N_BOOT = 2000

#: ``progress(done, total, what)`` after each alignment of a world finished or read back.
ProgressFn = Callable[[int, int, str], None]


#: An aligner parameter set: (name, value) pairs in order.
AlignerValues = tuple[tuple[str, int | float], ...]


@dataclass(frozen=True)
class JobRecord:
    """``job.json``: what the folder tunes (a folder holds one tune; ``level``: a suite's level, None: all;
    ``rule``: the recommendation rule, None: ``point``)."""

    source: str
    method: str
    overrides: list[str]
    level: str | None = field(default=None, metadata=OMIT_NONE)
    rule: str | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class WorldScenario:
    """``work/<world>/scenario.json``: a planned crossing world's scenario under its plan's key."""

    key: str
    scenario: dict[str, Any]


@dataclass(frozen=True)
class Outcomes:
    """``outcomes.json``: one world's pairs under one aligner parameter set, under the run's key.

    Per pair (in the run's order): its name ``a|b``, whether it is cross-robot, its robot pair,
    whether it is relevant and correct, its association count and its time (s; None: untimed).
    """

    key: str
    params: dict[str, int | float]
    pair: list[str]
    inter: list[bool]
    robots: list[str]
    relevant: list[bool]
    correct: list[bool]
    n_assoc: list[int]
    runtime_s: list[float | None] | None


@dataclass(frozen=True)
class WorldFacts:
    """``world.json``: a world's kilometres driven and, per gating setting, the pairs it gates out."""

    km: float
    gating: dict[str, list[str]] = field(default_factory=dict)


@dataclass(frozen=True)
class TuneWorld:
    """One world of a tune: its id and how to get its scenario (a scenario, or a crossing cell to plan)."""

    id: str
    scenario: Scenario | None = None
    cell: tuple[Any, int] | None = None  # (CrossingScene, seed)


def _kind(source: str) -> str:
    """``suite``, ``sweep`` or ``scenario``."""
    from roman_sim.benchmark.suites import SUITES

    if source in SUITES:
        return "suite"
    p = Path(source)
    if p.suffix in (".yaml", ".yml") and p.is_file():
        data = read_yaml(p)
        if isinstance(data, dict) and "grid" in data:
            return "sweep"
        if isinstance(data, dict) and ("levels" in data or "scene" in data):
            return "suite"
    return "scenario"


def load_worlds(
    source: str, method: str, seeds: list[int] | None, overrides: list[str], level: str | None = None
) -> list[TuneWorld]:
    """The worlds of ``source`` (see the module docstring), of ``level`` only when given.

    Raises:
        ConfigError: a level on a source without levels or one the suite does not have (naming
            the valid levels), or fewer than two worlds.
    """
    kind = _kind(source)
    worlds: list[TuneWorld] = []
    if level is not None and kind != "suite":
        raise ConfigError(
            f"--level: {source} is a {kind}, which has no levels (valid: none; --level takes a benchmark suite's level)"
        )
    if kind == "suite":
        from roman_sim.benchmark.suites import load_suite

        suite = load_suite(source)
        if level is not None and level not in suite.levels:
            raise ConfigError(f"--level: {source} has no level {level!r} (valid: {', '.join(suite.levels)})")
        for lv in [level] if level is not None else list(suite.levels):
            scene = suite.scene_at(lv, [method], overrides)
            worlds += [TuneWorld(f"{lv}-s{s}", cell=(scene, s)) for s in (seeds or suite.seeds)]
    elif kind == "sweep":
        from roman_sim.pipeline.scenario import load_scenario
        from roman_sim.pipeline.sweep import load_sweep
        from roman_sim.pipeline.sweep_spec import expand

        cfg, path = load_sweep(source)
        for run in expand(cfg):
            if seeds and run.seed not in seeds:
                continue
            sc = load_scenario(path, [*run.overrides, *overrides, f"seed={run.seed}"])
            worlds.append(TuneWorld(run.run_id, scenario=sc))
    else:
        from roman_sim.pipeline.scenario import load_scenario

        base = load_scenario(source, overrides)
        for s in seeds or [base.seed]:
            worlds.append(TuneWorld(f"s{s}", scenario=base.model_copy(update={"seed": s})))
    if len(worlds) < 2:
        raise ConfigError(
            f"worlds: {source} gives {len(worlds)} world; tuning needs at least two to split into calibration "
            "and held-out (give more with --seeds)"
        )
    return worlds


def tuned_scenario(sc: Scenario, method: str, params: dict[str, Any], name: str) -> Scenario:
    """``sc`` with ``method`` alone (its scenario parameters, then ``params``), no gating, no pose graph."""
    own = next((dict(e.params) for e in sc.aligners if e.method == method), {})
    data = sc.model_dump(mode="json")
    data.update(
        name=name,
        aligners=[{"method": method, "params": {**own, **params}}],
        posegraph_method=None,
        gating={**data["gating"], "enabled": False},
    )
    return validate_model(Scenario, data, source=f"tune world {name}")


def _path_km(T: np.ndarray | None) -> float:
    if T is None or len(T) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1).sum()) / 1000


def _read_kept(path: Path, cls: type[T]) -> T | None:
    """The record kept in ``path``; None when absent or damaged (it is computed again)."""
    try:
        return read_record(path, cls)
    except RecordError as err:
        if path.exists():
            log.warning("%s; computing it again", err)
        return None


class TuneJob:
    """One tune into one folder (see the module docstring).

    Args:
        source: scenario (name or YAML), sweep YAML or benchmark suite (name or YAML).
        method: the method tuned (a registered name or ``package.module:Class``).
        out_dir: the folder.
        params: ``NAME=SPEC`` items (``tune_space``); none: the method's defaults.
        target: the target precision, in (0, 1].
        seeds: the seeds (worlds) of a scenario or suite; a sweep's runs of these seeds.
        overrides: dotted scenario overrides of every world.
        level: a suite's level: its worlds only (None: every level).
        rule: the recommendation rule (``benchmark.tune_choice.RULES``).
        executor: where the runs' tasks run (None: this process).
        progress: called after each alignment of a world.
    """

    def __init__(
        self,
        source: str,
        method: str,
        out_dir: str | Path,
        params: list[str] | None = None,
        target: float = 0.9,
        seeds: list[int] | None = None,
        overrides: list[str] | None = None,
        executor: ExecutorConfig | None = None,
        progress: ProgressFn | None = None,
        level: str | None = None,
        rule: str = "world",
    ) -> None:
        check_target(target)
        self.rule = check_rule(rule)
        if seeds is not None and (len(set(seeds)) != len(seeds) or any(s < 0 for s in seeds)):
            raise ConfigError(f"--seeds: distinct non-negative integers, got {seeds}")
        self.source, self.method, self.target = source, method, float(target)
        self.values = parse_params(method, list(params or []))
        self.overrides = list(overrides or [])
        self.level = level
        self.worlds = load_worlds(source, method, seeds, self.overrides, level)
        self.grid: Grid = build_grid(method, self.values, self._base_params())
        self.out = Path(out_dir).resolve()
        self.executor = executor
        self.progress = progress or (lambda done, total, what: None)
        self._guard()

    def _base_params(self) -> dict[str, Any]:
        sc = next((w.scenario for w in self.worlds if w.scenario is not None), None)
        return next((dict(e.params) for e in sc.aligners if e.method == self.method), {}) if sc else {}

    def _guard(self) -> None:
        """Refuse a folder that holds something else, or another source's, level's or method's tune."""
        if self.out.exists() and not self.out.is_dir():
            raise ConfigError(f"--out {self.out}: not a folder")
        for other in ("manifest.json", "sweep.json", "benchmark.json"):
            if (self.out / other).is_file():
                raise ConfigError(f"--out {self.out}: holds a run, sweep or benchmark, not a tune (choose another)")
        if not (self.out / JOB_JSON).is_file():
            return
        old = read_record(self.out / JOB_JSON, JobRecord)
        if old != self._identity():
            on = old.source if old.level is None else f"{old.source} level {old.level}"
            rule = "" if old.rule == self._stored_rule else f" by rule {old.rule or 'point'}"
            raise ConfigError(
                f"--out {self.out}: holds the tune of {old.method!r} on {on!r} "
                f"with overrides {old.overrides}{rule} (choose another --out)"
            )

    @property
    def _stored_rule(self) -> str | None:
        """The rule as ``job.json`` and ``tune.json`` record it: None for ``point`` (the rule of every tune written
        before rules existed, so their files read and write back unchanged)."""
        return None if self.rule == "point" else self.rule

    def _identity(self) -> JobRecord:
        return JobRecord(self.source, self.method, self.overrides, self.level, self._stored_rule)

    # -- worlds and alignments ----------------------------------------------------
    def _scenario(self, w: TuneWorld) -> Scenario:
        if w.scenario is not None:
            return w.scenario
        from roman_sim.benchmark.scenes import build_crossing

        path = self.out / WORK_DIR / w.id / "scenario.json"
        assert w.cell is not None
        scene, seed = w.cell
        key = stable_hash(scene.model_dump(mode="json"), seed)
        rec = _read_kept(path, WorldScenario)
        if rec is not None and rec.key == key:
            return validate_model(Scenario, rec.scenario, source=str(path))
        sc = build_crossing(scene, seed, f"tune-{w.id}").scenario
        write_record(path, WorldScenario(key, sc.model_dump(mode="json")))
        return sc

    def _align(self, w: TuneWorld, aligner: AlignerValues, ex: Executor) -> Outcomes:
        """The outcomes of one world and aligner parameter set (run once, then read back)."""
        from roman_sim.benchmark.cells import CellExperiment
        from roman_sim.pipeline.stagecache import StageCache

        sc = tuned_scenario(self._scenario(w), self.method, dict(aligner), f"tune-{w.id}")
        folder = self.out / WORK_DIR / w.id / Config(aligner, ()).align_key
        chunk = self.executor.chunk_pairs if self.executor is not None else ExecutorConfig().chunk_pairs
        exp = CellExperiment(sc, folder / "run", executor=ex, chunk_pairs=chunk)
        key = exp.run_key()  # resolved parameters and code: a changed default aligns again
        rec = _read_kept(folder / OUTCOMES_JSON, Outcomes)
        if rec is not None and rec.key == key:
            return rec
        exp.cache = StageCache.default() or StageCache(self.out / CACHE_DIR)
        res = exp.run()
        rec = _outcomes(key, dict(aligner), res.run_dir, res.timings, sc)
        write_record(folder / OUTCOMES_JSON, rec, indent=None)
        return rec

    def _world_facts(self, w: TuneWorld, run_dir: Path, sc: Scenario) -> WorldFacts:
        """Kilometres driven and each gating setting's kept pairs (computed once per world and setting)."""
        path = self.out / WORK_DIR / w.id / WORLD_JSON
        old = _read_kept(path, WorldFacts)
        gatings = [c.gating for c in self.grid.configs if c.gating]
        want = {_gating_id(g): g for g in gatings}
        if old is not None and all(g in old.gating for g in want):
            return old
        from roman_sim.align.gating import GatingConfig, gate_pairs
        from roman_sim.evaluation.pairs import select_pairs
        from roman_sim.mapping.io import load_segment_map, load_submaps

        km = 0.0
        for r in sc.robots:
            m = load_segment_map(run_dir / "maps" / f"{r.name}.npz")
            km += _path_km(m.T_world_body if m.T_world_body is not None else m.T_odom_body)
        subs = [s for r in sc.robots for s in load_submaps(run_dir / "submaps" / f"{r.name}.npz")]
        pairs = select_pairs(subs, sc.evaluation).pairs
        kept = dict(old.gating) if old is not None else {}
        for gid, g in want.items():
            if gid in kept:
                continue
            cfg = validate_model(
                GatingConfig, {**sc.gating.model_dump(mode="json"), "enabled": True, "top_k": None, **dict(g)}
            )
            keep, _ = gate_pairs(pairs, cfg)
            kept[gid] = [f"{a.name}|{b.name}" for (a, b), k in zip(pairs, keep, strict=True) if not k]
        rec = WorldFacts(km, kept)
        write_record(path, rec, indent=None)
        return rec

    # -- the job ------------------------------------------------------------------
    def run(self) -> TuneResult:
        """Run (or read back) every alignment of every world, score, write the results; ``tune.json``'s content."""
        return self.score(*self.collect())

    def collect(self) -> tuple[dict[str, dict[AlignerValues, Outcomes]], dict[str, WorldFacts]]:
        """Run (or read back) every alignment of every world: per world its outcomes per aligner parameter
        set, and per world its kilometres and gated pairs."""
        self.out.mkdir(parents=True, exist_ok=True)
        write_record(self.out / JOB_JSON, self._identity())
        write_text(self.out / ".gitignore", f"{WORK_DIR}/\n{CACHE_DIR}/\n")
        aligners = self.grid.alignments()
        total = len(self.worlds) * len(aligners)
        done = 0
        per_world: dict[str, dict[AlignerValues, Outcomes]] = {}
        facts: dict[str, WorldFacts] = {}
        with open_executor(self.executor) as ex:
            for w in self.worlds:
                per_world[w.id] = {}
                for a in aligners:
                    per_world[w.id][a] = self._align(w, a, ex)
                    done += 1
                    self.progress(done, total, f"{w.id} {Config(a, ()).align_key}")
                first = self.out / WORK_DIR / w.id / Config(aligners[0], ()).align_key / "run"
                facts[w.id] = self._world_facts(w, first, self._scenario(w))
        return per_world, facts

    def _spread(self, c: ConfigOutcomes, k: int) -> TuneSpread | None:
        """The spread of the precision at threshold ``k`` of config ``c`` over every calibration world."""
        fit = setting_spread(c.pairs, k)
        if fit is None:
            return None
        return TuneSpread(
            a=fit.a,
            b=fit.b,
            worlds=fit.worlds,
            mean=fit.mean,
            share_at_target=fit.share(self.target),
            share_within_slack=fit.share(self.target - PRECISION_SLACK),
            interval=list(fit.interval(0.95)),
        )

    def score(self, per_world: dict[str, dict[AlignerValues, Outcomes]], facts: dict[str, WorldFacts]) -> TuneResult:
        """Score the outcomes (see ``benchmark.tune_choice``) and write the folder's results."""
        from roman_sim.benchmark.tune_plot import plot_front
        from roman_sim.benchmark.tune_space import declared

        spec = declared(self.method)
        configs = {c.id: config_outcomes(c, per_world, facts) for c in self.grid.configs}
        km = {w: float(f.km) for w, f in facts.items()}
        ks = self.grid.thresholds
        ev = Evidence(configs, km, ks, self.target, N_BOOT, 0, self.rule)
        rows, nested = config_rows(ev), nested_held_out(ev)
        rec = choose_setting(configs, km, sorted(km), ks, self.target, self.rule, N_BOOT, 0)
        if rec is None:
            log.warning("tune %s: no setting qualifies under rule %s: nothing recommended", self.method, self.rule)
        by_id = {c.id: c for c in self.grid.configs}
        result = TuneResult(
            source=self.source,
            level=self.level,
            rule=self._stored_rule,
            method=self.method,
            overrides=list(self.overrides),
            target_precision=self.target,
            parameters={n: [int(x) if spec[n].integer else x for x in v] for n, v in self.values.items()},
            worlds=[TuneWorldKm(w, round(km[w], 6)) for w in sorted(km)],
            configs=[
                TuneConfig(
                    id=r.config,
                    values=by_id[r.config].values(),
                    thresholds=r.thresholds,
                    time_per_pair_s=r.time_per_pair_s,
                    on_front=r.on_front,
                    **tuned_figures(r.figures, self.target),
                )
                for r in rows
            ],
            held_out=TuneHeldOut(
                chosen={w: None if s is None else TuneChoice(s.config, s.k) for w, s in nested.chosen.items()},
                per_world={
                    p.world: TuneWorldHeldOut(
                        p.hits, p.false_positives, p.precision, None if p.wilson is None else list(p.wilson)
                    )
                    for p in nested.per_world
                },
                precision_new_world=None if nested.new_world is None else list(nested.new_world),
                **tuned_figures(nested.figures, self.target),
            ),
            recommended=None
            if rec is None
            else TuneRecommended(
                rec.config,
                by_id[rec.config].values(),
                rec.k,
                rec.recall,
                rec.false_per_km,
                rec.time_per_pair_s,
                self._spread(configs[rec.config], rec.k),
            ),
        )
        write_tune(self.out / TUNE_JSON, result)
        plot_front(result, self.out / FRONT_PNG)
        yaml_path = self.out / RECOMMENDED_YAML
        if rec is not None:
            write_text(yaml_path, recommended_yaml(result, by_id[rec.config], self._base_params()))
        elif yaml_path.exists():
            yaml_path.unlink()
        return result


def _gating_id(g: tuple[tuple[str, int | float], ...]) -> str:
    return stable_hash(list(g))[:12]


def _outcomes(key: str, params: dict[str, int | float], run_dir: Path, timings: RunTimings, sc: Scenario) -> Outcomes:
    """The columns ``tune`` keeps of a finished run: every pair's names, kind, truth, outcome and time."""
    from roman_sim.evaluation.results import read_pairs_csv

    scores = read_pairs_csv(run_dir / "pairs.csv")
    label = sc.aligners[0].name
    ev = timings.stages.get("evaluation")
    own = None if ev is None or ev.alignment is None else ev.alignment.get(label)
    per_pair = None if own is None else own.per_pair_s
    rows = [s for s in scores if s.method == label]
    runtime: list[float | None] | None = None if per_pair is None else [float(x) for x in per_pair]
    if runtime is not None and len(runtime) != len(rows):
        raise StorageError(f"{run_dir}: {len(runtime)} pair times for {len(rows)} pairs")
    return Outcomes(
        key=key,
        params=params,
        pair=[f"{s.truth.a}|{s.truth.b}" for s in rows],
        inter=[s.truth.kind == "inter" for s in rows],
        robots=["|".join(sorted((s.truth.robot_a, s.truth.robot_b))) for s in rows],
        relevant=[bool(s.truth.relevant) for s in rows],
        correct=[bool(s.correct) for s in rows],
        n_assoc=[int(s.n_assoc) for s in rows],
        runtime_s=runtime,
    )


def config_outcomes(
    c: Config, per_world: dict[str, dict[AlignerValues, Outcomes]], facts: dict[str, WorldFacts]
) -> ConfigOutcomes:
    """One config's cross-robot outcomes over every world: its alignment's, with its gating applied."""
    cols: dict[str, list[Any]] = {k: [] for k in ("world", "cluster", "relevant", "correct", "score", "runtime")}
    for w in sorted(per_world):
        rec = per_world[w][c.aligner]
        gated = set(facts[w].gating[_gating_id(c.gating)]) if c.gating else set()
        times = rec.runtime_s or [None] * len(rec.pair)
        for i, name in enumerate(rec.pair):
            if not rec.inter[i]:
                continue
            out = name in gated
            cols["world"].append(w)
            cols["cluster"].append(rec.robots[i])
            cols["relevant"].append(rec.relevant[i])
            cols["correct"].append(rec.correct[i] and not out)
            cols["score"].append(0 if out else rec.n_assoc[i])
            t = times[i]
            cols["runtime"].append(0.0 if out else (float("nan") if t is None else t))
    o = PairOutcomes.from_lists(cols["world"], cols["cluster"], cols["relevant"], cols["correct"], cols["score"])
    return ConfigOutcomes(o, np.asarray(cols["runtime"], dtype=np.float64))


def _pair(ci: tuple[float, float] | None) -> list[float] | None:
    return None if ci is None else [float(ci[0]), float(ci[1])]


def held_out_figures(c: HeldOutCell, target: float) -> HeldOutFigures:
    """A held-out cell of the tune as its records hold it, with whether its precision transfers."""
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


def tuned_figures(f: Figures, target: float) -> dict[str, Any]:
    """The fields of ``TunedFigures`` for ``f`` at ``target`` (keyword arguments of it and its subclasses)."""
    h = held_out_figures(f.cell, target)
    return {**{x.name: getattr(h, x.name) for x in fields(h)}, "false_per_km": f.false_per_km}


def recommended_sections(method: str, c: Config, k: int, base_params: dict[str, Any]) -> dict[str, Any]:
    """The scenario sections of a recommended setting: the method with its parameters, gating, threshold."""
    return {
        "aligners": [{"method": method, "params": {**base_params, **dict(c.aligner)}}],
        "posegraph_method": method,
        "posegraph": {"lc_association_thresh": int(k)},
        "gating": c.gating_config(),
    }


def spread_lines(sp: TuneSpread | None, target: float) -> list[str]:
    """The recommended setting's spread over worlds as ``recommended.yaml`` header lines (none without a fit)."""
    if sp is None:
        return []
    return [
        f"# worlds' spread (beta-binomial over {sp.worlds} worlds): a new world's precision {sp.mean:.3f} expected, "
        f"95 % of worlds in [{sp.interval[0]:.3f}, {sp.interval[1]:.3f}]; {sp.share_at_target:.1%} of worlds at "
        f"{target:g} or more, {sp.share_within_slack:.1%} at {target - PRECISION_SLACK:g} or more",
    ]


def recommended_yaml(result: TuneResult, c: Config, base_params: dict[str, Any]) -> str:
    """``recommended.yaml``: the sections, headed by comments stating the held-out figures."""
    import yaml

    rec, h = result.recommended, result.held_out
    if rec is None:
        raise ValueError("recommended_yaml: the tune recommends no setting")

    def ci(v: list[float] | None) -> str:
        return "n/a" if v is None else f"[{v[0]:.3f}, {v[1]:.3f}]"

    def num(v: float | None) -> str:
        return "n/a" if v is None else f"{v:.3f}"

    head = [
        f"# roman-sim tune: {result.method} on {result.source}"
        + ("" if result.level is None else f", level {result.level}")
        + f", target precision {result.target_precision:g}"
        + ("" if result.rule is None else f", rule {result.rule}"),
        f"# chosen on {len(result.worlds)} worlds: threshold {rec.threshold}, "
        + ", ".join(f"{k}={v}" for k, v in rec.values.items()),
        f"# held-out (each world scored at the setting chosen on the others): precision {num(h.precision)} "
        f"{ci(h.precision_worlds)}, recall {num(h.recall)} {ci(h.recall_worlds)} (95 % world bootstrap)",
        f"# precision in one new world: {ci(h.precision_new_world)} (every held-out world's Wilson interval "
        f"and the pooled one; {len(result.worlds)} worlds)",
        *spread_lines(rec.spread, result.target_precision),
        "# use: paste these sections into a scenario, or: roman-sim run SCENARIO --set @recommended.yaml",
    ]
    body = yaml.safe_dump(recommended_sections(result.method, c, rec.threshold, base_params), sort_keys=False)
    return "\n".join(head) + "\n" + body


__all__ = ["THRESHOLD", "TuneJob", "load_worlds", "recommended_sections", "tuned_scenario"]
