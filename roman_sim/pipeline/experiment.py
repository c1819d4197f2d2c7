"""``Experiment``: runs the stage table on one scenario into a run folder.

The experiment only orders, caches, times and measures memory; the stages do the work
(``roman_sim.pipeline.stages``). Before any stage runs it writes ``config.yaml`` and a
``manifest.json`` that keeps only the stages whose cache keys still match (their outputs
are reused; the files of every other stage are deleted, so nothing stale can be read or
reported), then runs the rest in order, recording each stage in the manifest as it
finishes; what later stages receive is the output as saved and read back, so a fresh and a
cached stage give the same bytes downstream. A cached stage is loaded only when a stage that
runs needs its output. Wall-clock
figures (per stage and per pair) go to ``timings.json``, never into the other outputs.

The scenario is resolved first (every aligner's, segmenter's and encoder's parameters with
their defaults, ``roman_sim.pipeline.resolve``): ``config.yaml`` records it and the
stages' keys hash it with the fingerprint of the code each stage runs. A stage its folder
does not hold is taken from the shared stage cache when another run computed it with the
same key (``roman_sim.pipeline.stagecache``), and every completed stage is stored there.

Each stage gets its inputs as the dataclass it declares (built from the upstream outputs)
and a ``TaskRunner``: independent tasks (one per robot to map, one per chunk of pairs to
align) run on the executor ``executor`` describes (this process by default; a local pool or
Dask), and each finished task is checkpointed under ``partial/<stage>/`` with the stage's
cache key, so an interrupted stage resumes with the unfinished tasks; the checkpoints are
removed once the stage completes. A stage's ``run`` writes nothing; the experiment calls its
``save`` and records its files. The wall-clock figures a stage returns in its output
(``timings``) go to ``timings.json`` with the stage's time and peak memory.
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Sized
from dataclasses import replace
from pathlib import Path
from typing import cast

from roman_sim import __version__
from roman_sim.core.atomic import write_text
from roman_sim.core.config import dump_yaml, stable_hash
from roman_sim.core.errors import ConfigError, RomanSimError, StorageError
from roman_sim.core.records import RecordError
from roman_sim.core.resources import peak_rss_mb, reset_peak_rss
from roman_sim.evaluation.records import run_timings, write_timings
from roman_sim.pipeline.context import NullProgress, Progress, RunContext
from roman_sim.pipeline.folder_lock import hold_run_folder, holds_run_folder
from roman_sim.pipeline.manifest import Manifest, StageRecord, environment, existing_manifest
from roman_sim.pipeline.result import RESULT_STAGES, TIMINGS_JSON, RunResult, read_timings
from roman_sim.pipeline.scenario import Scenario, default_run_dir, load_scenario
from roman_sim.pipeline.stagecache import StageCache
from roman_sim.pipeline.stages import STAGE_NAMES, STAGES, WORKER_PRELOAD, Stage, StageOutput
from roman_sim.pipeline.stages.base import Timings
from roman_sim.runner.checkpoint import Checkpoint, clear_checkpoints
from roman_sim.runner.executors import Executor, ExecutorConfig, open_executor
from roman_sim.runner.taskrunner import TaskRunner

log = logging.getLogger(__name__)


class Experiment:
    """Runs a scenario into ``run_dir``.

    Args:
        scenario: the validated scenario.
        run_dir: results folder (created; completed stages inside are reused).
        fresh: ignore cached stages and recompute everything.
        progress: progress sink (the CLI passes rich progress bars).
        submaps_dir: start from saved submaps (``<robot>.npz`` files of
            ``roman_sim.mapping.io.save_submaps``, one per robot of the scenario) instead of
            simulating and mapping.
        from_stage: recompute this stage and every later one, reuse the earlier ones
            (e.g. ``"evaluation"`` after changing an aligner's code).
        executor: where tasks run (``ExecutorConfig``, an open ``Executor`` the caller
            closes, or None: in this process).
        cache: the shared stage cache (True: ``StageCache.default()``, which
            ``$ROMAN_SIM_CACHE=off`` turns off; False: none).
    """

    def __init__(
        self,
        scenario: Scenario,
        run_dir: str | Path,
        fresh: bool = False,
        progress: Progress | None = None,
        submaps_dir: str | Path | None = None,
        from_stage: str | None = None,
        executor: ExecutorConfig | Executor | None = None,
        cache: StageCache | bool = True,
    ) -> None:
        if from_stage is not None and from_stage not in STAGE_NAMES:
            raise ConfigError(f"from_stage: unknown stage {from_stage!r} (valid: {', '.join(STAGE_NAMES)})")
        self.scenario = scenario
        self.run_dir = Path(run_dir)
        self.fresh = fresh
        self.from_stage = from_stage
        self.progress: Progress = progress or NullProgress()
        self.submaps_dir = Path(submaps_dir) if submaps_dir else None
        self.executor = executor
        self.cache = StageCache.default() if cache is True else (cache or None)
        self._validated = False

    def context(self) -> RunContext:
        """The run context the stages see."""
        chunk = self.executor.chunk_pairs if isinstance(self.executor, ExecutorConfig) else ExecutorConfig().chunk_pairs
        return RunContext(self.scenario, self.run_dir, self.progress, self.fresh, self.submaps_dir, chunk_pairs=chunk)

    def validate(self) -> None:
        """Resolve the scenario's components, then check what can be checked before any work:
        world spec, recorded sequences and odometry files (``maps_input.check_inputs``), aligners,
        plug-ins, RGB, output folder. ``run`` calls it unless it was called.

        Every user plug-in (``package.module:Class``) is imported, built, checked against its
        protocol and called once on a tiny synthetic input (``roman_sim.core.plugins``), so a
        broken one fails here in one line instead of after the expensive stages.
        """
        from roman_sim.pipeline.resolve import resolve_scenario

        self.scenario = resolve_scenario(self.scenario)
        if self.submaps_dir is None:
            from roman_sim.pipeline.stages.maps_input import check_inputs

            if self.scenario.needs_world:
                self.scenario.world.spec()
            check_inputs(self.context())
        elif not self.submaps_dir.is_dir():
            raise ConfigError(f"--submaps {self.submaps_dir}: not a folder")
        self._check_plugins()
        self._prepare_dir()
        self._validated = True

    def _check_plugins(self) -> None:
        from roman_sim.align import build_aligner
        from roman_sim.core.plugins import instantiate_plugin
        from roman_sim.frontend.components import check_frontend
        from roman_sim.pipeline.plugin_guard import is_plugin
        from roman_sim.pipeline.plugins import dry_call

        sc = self.scenario
        fe = sc.frontend
        with_rgb = all(r.render_rgb for r in sc.robots)
        dim = fe.semantics.dim
        if self.submaps_dir is None:  # the front end runs only when the run maps its own frames
            # Imports user front-end classes; every robot must render the RGB the front end needs;
            # model folders must exist.
            check_frontend(fe, sc.robots)
            if is_plugin(fe.segmenter.name):
                seg = instantiate_plugin(fe.segmenter.name, "segmenter", fe.segmenter.params)
                dry_call(seg, fe.segmenter.name, "segmenter", with_rgb=with_rgb)
            if is_plugin(fe.encoder.name):
                enc = instantiate_plugin(fe.encoder.name, "encoder", fe.encoder.params)
                # the dry call checked that the encoder returns a 1-d vector
                dim = len(cast(Sized, dry_call(enc, fe.encoder.name, "encoder", with_rgb=with_rgb)))
        for entry in sc.aligners:
            aligner = build_aligner(entry.method, entry.params)
            if is_plugin(entry.method):
                dry_call(aligner, entry.method, "aligner", descriptor_dim=dim)

    def _prepare_dir(self) -> None:
        try:
            self.run_dir.mkdir(parents=True, exist_ok=True)
            probe = self.run_dir / ".write_probe"
            probe.write_bytes(b"")
            probe.unlink(missing_ok=True)  # a second run into the folder may have removed it
        except OSError as err:
            raise ConfigError(f"--out {self.run_dir}: cannot write there ({err.strerror or err})") from None

    # -- planning --------------------------------------------------------------
    def stage_keys(self) -> dict[str, str]:
        """The cache key of every stage the run runs, as the run computes them; nothing is run or written.

        The keys hash the scenario with every component's parameters resolved (defaults filled
        in) and the fingerprint of the code each stage runs.
        """
        from roman_sim.pipeline.resolve import resolve_scenario

        ctx = replace(self.context(), scenario=resolve_scenario(self.scenario))
        return self._keys(ctx, [s for s in STAGES if s.applies(ctx)])

    def run_key(self) -> str:
        """What the run's results depend on: ``stage_keys`` hashed. A job that keeps a finished run's
        figures (a benchmark cell, a tune's alignment) runs it again when the key changes: a changed
        default or changed code."""
        return stable_hash(sorted(self.stage_keys().items()))

    def _keys(self, ctx: RunContext, active: list[Stage]) -> dict[str, str]:
        keys: dict[str, str] = {}
        for stage in active:
            keys[stage.name] = stage.key(ctx, {i: keys.get(i) for i in stage.inputs})
        return keys

    def _may_reuse(self, stage: Stage) -> bool:
        if not stage.cached or self.fresh:
            return False
        return self.from_stage is None or STAGE_NAMES.index(stage.name) < STAGE_NAMES.index(self.from_stage)

    def _reusable(self, stage: Stage, key: str, old: Manifest | None) -> bool:
        """Whether the folder's own files of ``stage`` are reused: recorded with ``key`` and unchanged."""
        if old is None or not self._may_reuse(stage):
            return False
        why = old.check(stage.name, key, self.run_dir)
        if why is not None and stage.name in old.stages and old.stages[stage.name].key == key:
            log.warning("stage %s: %s; computing it again", stage.name, why)
        return why is None

    def _shared(
        self, ctx: RunContext, active: list[Stage], keys: dict[str, str], reuse: set[str], manifest: Manifest
    ) -> set[str]:
        """Take the stages this folder lacks from the shared cache; store those it holds there; the names taken."""
        if self.cache is None:
            return set()
        taken: set[str] = set()
        for stage in active:
            if stage.name in reuse:
                self._publish(stage, ctx, manifest.stages[stage.name])
            elif self._may_reuse(stage):
                files = self.cache.fetch(stage.name, keys[stage.name], self.run_dir)
                if files is not None:
                    manifest.stages[stage.name] = StageRecord.of(keys[stage.name], self.run_dir, list(files))
                    taken.add(stage.name)
        if taken:
            manifest.save(self.run_dir)
        return taken

    def _publish(self, stage: Stage, ctx: RunContext, rec: StageRecord) -> None:
        """Store a completed stage in the shared cache, and the parts it keeps apart (``Stage.parts``)."""
        if self.cache is None:
            return
        if rec.sha256 is None:  # an old manifest without hashes: nothing verified to publish
            return
        files = {f: rec.sha256.get(f) for f in rec.files}
        self.cache.publish(stage.name, rec.key, self.run_dir, files)
        for part in stage.parts(ctx):
            if all(f in files for f in part.files):
                self.cache.publish(part.name, part.key, self.run_dir, {f: files[f] for f in part.files})

    def _start_manifest(
        self, old: Manifest | None, keys: dict[str, str], reuse: set[str], active: list[Stage]
    ) -> Manifest:
        """The manifest of this run before any stage runs; outputs of stale stages are deleted."""
        keep = {name: old.stages[name] for name in reuse} if old else {}
        for name, rec in old.stages.items() if old else []:
            if name not in reuse:
                for f in rec.files:
                    (self.run_dir / f).unlink(missing_ok=True)
        # the stages' keys hold the versions of the libraries each runs: a kept stage was made with these
        env = environment()
        man = Manifest(
            self.scenario.name,
            self.scenario.seed,
            self.scenario.config_hash(),
            __version__,
            keep,
            [s.name for s in active if s.cached],
            env,
        )
        write_text(self.run_dir / "config.yaml", dump_yaml(self.scenario))
        man.save(self.run_dir)
        return man

    # -- the run -----------------------------------------------------------------
    def run(self) -> RunResult:
        """Run every stage (reusing cached ones) and return the result.

        The run holds its folder's lock throughout (``roman_sim.pipeline.folder_lock``): a
        second run into the same folder stops with ``RunFolderBusy`` before writing anything.
        """
        if not self._validated:
            self.validate()
        held = holds_run_folder(self.run_dir)  # the command line locks first, before its start-up work
        with contextlib.nullcontext() if held else hold_run_folder(self.run_dir):
            if isinstance(self.executor, Executor):
                return self._run(self.executor)
            with open_executor(self.executor, WORKER_PRELOAD) as ex:
                return self._run(ex)

    def _run(self, ex: Executor) -> RunResult:
        from roman_sim.pipeline.plugins import plugin_modules

        ex.check_imports(plugin_modules(self.scenario))
        ctx = self.context()
        if self.fresh:
            clear_checkpoints(self.run_dir)
        active = [s for s in STAGES if s.applies(ctx)]
        keys = self._keys(ctx, active)
        old = existing_manifest(self.run_dir)
        reuse = {s.name for s in active if self._reusable(s, keys[s.name], old)}
        manifest = self._start_manifest(old, keys, reuse, active)
        ctx = replace(ctx, keys=keys, cache=self.cache, environment=manifest.environment)
        reuse |= self._shared(ctx, active, keys, reuse, manifest)
        needed = {i for s in active if s.name not in reuse for i in s.inputs} | set(RESULT_STAGES)
        timings = self._old_timings(reuse)
        if any(s.uses_workers for s in active if s.name not in reuse):
            ex.start()  # the workers start up while the stages before their first task (the world) run
        outputs: dict[str, StageOutput] = {}
        for stage in active:
            if stage.name in reuse:
                if stage.name in needed:
                    outputs[stage.name] = self._load(stage, ctx, manifest.stages[stage.name].files)
                continue
            if not stage.cached and stage.name not in needed:
                continue
            outputs[stage.name], timings[stage.name] = self._run_stage(stage, ctx, outputs, manifest, keys, ex)
        checked = run_timings(timings, str(self.run_dir / TIMINGS_JSON))
        write_timings(self.run_dir / TIMINGS_JSON, checked)
        log.info(
            "run %s complete in %s (reused: %s)", self.scenario.name, self.run_dir, ", ".join(sorted(reuse)) or "none"
        )
        return RunResult.from_outputs(
            self.run_dir, self.scenario, outputs, checked, [s.name for s in active if s.name in reuse]
        )

    def _run_stage(
        self,
        stage: Stage,
        ctx: RunContext,
        outputs: dict[str, StageOutput],
        manifest: Manifest,
        keys: dict[str, str],
        ex: Executor,
    ) -> tuple[StageOutput, Timings]:
        reset_peak_rss()
        t0 = time.perf_counter()
        if not self._may_reuse(stage):  # --fresh or --from: no part of it is taken from the shared cache either
            ctx = replace(ctx, cache=None)
        self.progress.start(stage.name)
        inputs = stage.build_inputs(outputs)
        tasks = TaskRunner(ex, Checkpoint(self.run_dir, stage.name, keys[stage.name]) if stage.cached else None)
        out: StageOutput = stage.run(ctx, inputs, tasks)
        own = dict(out.timings)
        if stage.cached:
            files = stage.save(out, ctx)
            manifest.stages[stage.name] = StageRecord.of(keys[stage.name], self.run_dir, files)
            manifest.save(self.run_dir)
            self._publish(stage, ctx, manifest.stages[stage.name])
            clear_checkpoints(self.run_dir, stage.name)
            # Later stages get exactly what a cached re-run would load (saving may round), so a run
            # gives the same bytes whether its earlier stages were computed or reused.
            out = stage.load(ctx, files)
        self.progress.end(stage.name)  # after the manifest: a stage reported done is a stage kept
        seconds = time.perf_counter() - t0
        peak = peak_rss_mb()
        log.info("stage %s: %.1f s", stage.name, seconds)
        return out, {
            "seconds": round(seconds, 3),
            "peak_rss_mb": None if peak is None else round(peak, 1),
            "reused": False,
            **own,
        }

    def _load(self, stage: Stage, ctx: RunContext, files: list[str]) -> StageOutput:
        log.info("stage %s: reusing cached results", stage.name)
        try:
            return stage.load(ctx, files)
        except RomanSimError as err:
            raise StorageError(
                f"cached stage {stage.name!r} in {self.run_dir} is unusable: {err} (re-run with --fresh)"
            ) from None

    def _old_timings(self, reuse: set[str]) -> dict[str, Timings]:
        """Timings of the reused stages, from the previous run's ``timings.json``."""
        try:
            old = read_timings(self.run_dir)
        except RecordError as err:
            log.warning("previous timings not kept: %s", err)
            old = {}
        return {name: {**old.get(name, {}), "reused": True} for name in STAGE_NAMES if name in reuse}


def is_current_run(run_dir: Path, scenario: Scenario) -> bool:
    """Whether ``run_dir`` holds a complete run of ``scenario`` (resolved) under the keys a run would
    compute now: a changed default or changed code of a stage makes it stale (``Experiment.stage_keys``)."""
    from roman_sim.pipeline.resolve import resolve_scenario

    man = existing_manifest(run_dir)
    if man is None or not man.complete:
        return False
    sc = resolve_scenario(scenario)
    if man.config_hash != sc.config_hash():  # the run folder records it resolved
        return False
    keys = Experiment(sc, run_dir, cache=False).stage_keys()
    return all(name in keys and man.valid(name, keys[name], run_dir) for name in man.expected)


def run_scenario_file(
    name_or_path: str | Path,
    overrides: list[str] | None = None,
    run_dir: str | Path | None = None,
    fresh: bool = False,
    progress: Progress | None = None,
    from_stage: str | None = None,
    executor: ExecutorConfig | Executor | None = None,
) -> RunResult:
    """Load a scenario (bundled name or path), apply overrides, run it, return the result."""
    sc = load_scenario(name_or_path, overrides)
    out = Path(run_dir) if run_dir else default_run_dir(sc)
    return Experiment(sc, out, fresh=fresh, progress=progress, from_stage=from_stage, executor=executor).run()


__all__ = ["Experiment", "NullProgress", "Progress", "RunResult", "default_run_dir", "run_scenario_file"]
