"""``Experiment``: the whole pipeline of one scenario as a list of named, cached stages.

world -> robots (render + map, per robot) -> submaps -> alignment evaluation (every
aligner on every pair) -> pose graph (odometry only, the chosen method's closures, oracle
closures) -> trajectory error -> report. Each stage writes its outputs atomically into the
run folder and records a hash of the configuration it depends on in ``stages.json``; a
re-run reuses every stage whose hash still matches and whose files exist.
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol


from roman_sim.core.atomic import write_json, write_text
from roman_sim import __version__
from roman_sim.core.config import dump_yaml
from roman_sim.core.errors import ConfigError
from roman_sim.core.resources import peak_rss_mb, reset_peak_rss
from roman_sim.pipeline.scenario import Scenario, load_scenario

log = logging.getLogger(__name__)

STAGES = ("world", "maps", "submaps", "evaluation", "posegraph", "report")


class Progress(Protocol):
    """Progress sink (the CLI draws bars; the library default ignores everything)."""

    def start(self, stage: str, total: int | None = None) -> None: ...

    def advance(self, stage: str, n: int = 1) -> None: ...

    def end(self, stage: str) -> None: ...


class NullProgress:
    """A ``Progress`` that reports nothing."""

    def start(self, stage: str, total: int | None = None) -> None:
        pass

    def advance(self, stage: str, n: int = 1) -> None:
        pass

    def end(self, stage: str) -> None:
        pass


@dataclass
class RunResult:
    """What a run produced (everything is also on disk in ``run_dir``)."""

    run_dir: Path
    scenario: Scenario
    metrics: dict[str, Any]
    ate: dict[str, Any]
    map_stats: dict[str, Any]
    stage_seconds: dict[str, float] = field(default_factory=dict)
    stage_peak_mb: dict[str, float | None] = field(default_factory=dict)
    reused: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def recall(self, method: str, heading_bin: str | None = None) -> float | None:
        """Max recall of ``method`` overall or in a coarse heading bin such as ``"120-180"``."""
        from roman_sim.evaluation.summaries import method_recall

        return method_recall(self.metrics, method, heading_bin)

    def metrics_summary(self) -> dict[str, Any]:
        """A compact JSON-ready summary (per method recall, runtime; ATE; map size)."""
        from roman_sim.evaluation.summaries import compact_summary

        return compact_summary(self.metrics, self.ate, self.map_stats)


def _hash(*parts: Any) -> str:
    blob = json.dumps(parts, sort_keys=True, default=str).encode("utf-8")
    return hashlib.sha256(blob).hexdigest()[:16]


class Experiment:
    """Runs a scenario into ``run_dir``.

    Args:
        scenario: the validated scenario.
        run_dir: results folder (created; completed stages inside are reused).
        fresh: ignore cached stages and recompute everything.
        progress: progress sink (the CLI passes rich progress bars).
        submaps_dir: start from saved submaps (``<robot>.npz`` files of
            ``roman_sim.mapping.io.save_submaps``) instead of simulating and mapping.
        from_stage: recompute this stage and every later one, reuse the earlier ones
            (e.g. ``"evaluation"`` after changing an aligner's code).
    """

    def __init__(
        self,
        scenario: Scenario,
        run_dir: str | Path,
        fresh: bool = False,
        progress: Progress | None = None,
        submaps_dir: str | Path | None = None,
        from_stage: str | None = None,
    ) -> None:
        if from_stage is not None and from_stage not in STAGES:
            raise ConfigError(f"from_stage: unknown stage {from_stage!r} (valid: {', '.join(STAGES)})")
        self.from_stage = from_stage
        self.sc = scenario
        self.dir = Path(run_dir)
        self.fresh = fresh
        self.progress = progress or NullProgress()
        self.submaps_dir = Path(submaps_dir) if submaps_dir else None
        self._state: dict[str, Any] = {}
        self._stages_file = self.dir / "stages.json"
        self.result = RunResult(self.dir, scenario, {}, {}, {})

    # -- cache bookkeeping -------------------------------------------------
    def _stages(self) -> dict[str, Any]:
        if not self._stages_file.is_file():
            return {}
        try:
            data = json.loads(self._stages_file.read_text())
            return data if isinstance(data, dict) else {}
        except (OSError, json.JSONDecodeError):
            log.warning("%s is corrupt: recomputing every stage", self._stages_file)
            return {}

    def _cached(self, stage: str, key: str, files: list[Path]) -> bool:
        if self.fresh:
            return False
        if self.from_stage is not None and STAGES.index(stage) >= STAGES.index(self.from_stage):
            return False
        rec = self._stages().get(stage)
        return bool(rec and rec.get("key") == key and all(f.exists() for f in files))

    def _mark(self, stage: str, key: str, seconds: float, peak_mb: float | None) -> None:
        stages = self._stages()
        stages[stage] = {"key": key, "seconds": round(seconds, 3),
                         "peak_rss_mb": None if peak_mb is None else round(peak_mb, 1)}
        write_json(self._stages_file, stages)

    # -- keys ----------------------------------------------------------------
    def _keys(self) -> dict[str, str]:
        sc = self.sc.model_dump(mode="json")
        src = str(self.submaps_dir) if self.submaps_dir else None
        # the package version is part of every key: results of an older release are not reused
        maps = _hash(__version__, sc["seed"], sc["world"], sc["robots"], sc["frontend"], sc["mapping"])
        submaps = _hash(maps, sc["submaps"], src)
        evaluation = _hash(submaps, sc["aligners"], sc["evaluation"])
        posegraph = _hash(evaluation, sc["posegraph"], sc["posegraph_method"])
        return {"maps": maps, "submaps": submaps, "evaluation": evaluation, "posegraph": posegraph}

    # -- the run ---------------------------------------------------------------
    def validate(self) -> None:
        """Check what can be checked before any work: world spec, aligners, plug-ins, output folder."""
        from roman_sim.align import build_aligner
        from roman_sim.core.registry import import_object

        if self.submaps_dir is None:
            self.sc.world.spec()
        elif not self.submaps_dir.is_dir():
            raise ConfigError(f"--submaps {self.submaps_dir}: not a folder")
        for entry in self.sc.aligners:
            build_aligner(entry.method, entry.params)
        fe = self.sc.frontend
        for kind, name in (("segmenter", fe.segmenter), ("semantic encoder", fe.encoder)):
            if isinstance(name, str) and ":" in name:
                import_object(name, kind)
        self._prepare_dir()

    def run(self) -> RunResult:
        """Run every stage (reusing cached ones) and return the result."""
        from roman_sim.pipeline import stages as st

        self.validate()
        write_text(self.dir / "config.yaml", dump_yaml(self.sc))
        keys = self._keys()
        steps: list[tuple[str, Callable[[], None], list[Path] | None]] = [
            ("world", lambda: st.world_stage(self), None),
            ("maps", lambda: st.maps_stage(self), st.map_files(self)),
            ("submaps", lambda: st.submaps_stage(self), st.submap_files(self)),
            ("evaluation", lambda: st.evaluation_stage(self), st.evaluation_files(self)),
            ("posegraph", lambda: st.posegraph_stage(self), st.posegraph_files(self)),
            ("report", lambda: st.report_stage(self), None),
        ]
        for name, fn, files in steps:
            if self.submaps_dir and name in ("world", "maps"):
                continue
            key = keys.get(name)
            if key and files is not None and self._cached(name, key, files):
                log.info("stage %s: reusing cached results", name)
                self.result.reused.append(name)
                st.load_stage(self, name)
                continue
            reset_peak_rss()
            t0 = time.perf_counter()
            self.progress.start(name)
            fn()
            self.progress.end(name)
            secs = time.perf_counter() - t0
            self.result.stage_seconds[name] = secs
            self.result.stage_peak_mb[name] = peak_rss_mb()
            if key:
                self._mark(name, key, secs, self.result.stage_peak_mb[name])
        return self.result

    def _prepare_dir(self) -> None:
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
            probe = self.dir / ".write_probe"
            probe.write_bytes(b"")
            probe.unlink()
        except OSError as err:
            raise ConfigError(f"--out {self.dir}: cannot write there ({err.strerror or err})") from None


def run_scenario_file(
    name_or_path: str | Path,
    overrides: list[str] | None = None,
    run_dir: str | Path | None = None,
    fresh: bool = False,
    progress: Progress | None = None,
    from_stage: str | None = None,
) -> RunResult:
    """Load a scenario (bundled name or path), apply overrides, run it, return the result."""
    sc = load_scenario(name_or_path, overrides)
    out = Path(run_dir) if run_dir else default_run_dir(sc)
    return Experiment(sc, out, fresh=fresh, progress=progress, from_stage=from_stage).run()


def default_run_dir(sc: Scenario, root: str | Path = "results") -> Path:
    """``results/<scenario>/seed<seed>-<config hash>``: stable, so re-runs reuse stages."""
    h = _hash(sc.model_dump(mode="json"))[:8]
    return Path(root) / sc.name / f"seed{sc.seed}-{h}"


__all__ = ["Experiment", "NullProgress", "Progress", "RunResult", "default_run_dir", "run_scenario_file"]
