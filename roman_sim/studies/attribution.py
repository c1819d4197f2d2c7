"""The attribution study: how much of the same -> opposite drop in max recall each heading mechanism explains.

``run_attribution`` runs a same-direction and an opposite-direction scenario with every
mechanism on (``none``) and with each mechanism of ``mechanisms`` switched off in turn
(``roman_sim.studies.mechanisms``), each run a run folder made by the ordinary pipeline.
Worlds are the unit of replication: with ``seeds`` every (role, mechanism) runs in each
world (the scenario's ``seed`` set to each value; both roles of one seed share their world),
in ``<out>/runs/<role>__<mechanism>__s<seed>/``; without, once in the scenario's own world,
in ``<out>/runs/<role>__<mechanism>/``. A finished run whose resolved configuration is
unchanged is not run again, so an interrupted study resumes where it stopped.

For each mechanism and method (cross-robot pairs), counts pooled over the worlds (each
world's hits, relevant pairs and false positives at its own max-recall point, summed): max
recall (hits / relevant) in each direction with its Wilson interval and the precision at
that operating point; the drop ``same - opposite`` with Newcombe's interval for a difference
of independent proportions (hybrid score, from the two Wilson intervals) and, with two or
more worlds, a world-bootstrap interval (``drop_bootstrap``: pairs within a world are not
independent draws, worlds are); and the share of the all-on drop that switching the
mechanism off removes, ``(drop_none - drop_off) / drop_none``. Written
atomically: ``attribution.json`` (the configuration and the runs) and ``attribution.csv``
(the table). ``collect_attribution`` keeps the runs' raw pairs next to them, from which the
independent scorer re-derives the table.

Sizes: both scenarios keep their worlds and paths; ``STUDY_OVERRIDES`` shrink the images
(256 x 192), the frame rate (3 Hz) and the world (60 x 60 m) and drop RGB (no method of
the study reads it), so that the whole study fits in about 25 minutes on two cores.
"""

from __future__ import annotations

import csv
import io
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, field_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.records import write_record
from roman_sim.evaluation.intervals import wilson
from roman_sim.runner.executor_base import ExecutorConfig
from roman_sim.studies.mechanisms import ALL_ON, check_mechanisms, mechanism_overrides

log = logging.getLogger(__name__)

PLAN, TABLE = "attribution.json", "attribution.csv"
SCHEMA = "roman_sim.attribution/1"
ROLES = ("same", "opposite")

#: The study's default mechanisms (each switched off in turn).
DEFAULT_MECHANISMS = ("descriptor_view", "lighting", "partial_views", "segmenter_view", "road_side")

#: Sizes of the study's runs, applied to both scenarios (see the module docstring).
STUDY_OVERRIDES = (
    "world.overrides.extent_m=[60.0, 60.0]",
    *(f"robots.{i}.{k}" for i in (0, 1) for k in ("camera.width=256", "camera.height=192", "rate_hz=3.0")),
    *(f"robots.{i}.render_rgb=false" for i in (0, 1)),
)


@dataclass
class AttributionRow:
    """One row of ``attribution.csv``: a mechanism switched off (``none``: all on) and a method; per
    role (``same`` / ``opposite`` direction) the pooled hits, relevant pairs, recall with its Wilson
    interval and precision; the drop with Newcombe's and the world bootstrap's intervals; and the
    share of the all-on drop it explains (None where undefined)."""

    mechanism: str
    method: str
    worlds: int
    same_hits: int
    same_relevant: int
    same_recall: float | None
    same_recall_lo: float | None
    same_recall_hi: float | None
    same_precision: float | None
    opposite_hits: int
    opposite_relevant: int
    opposite_recall: float | None
    opposite_recall_lo: float | None
    opposite_recall_hi: float | None
    opposite_precision: float | None
    drop: float | None
    drop_lo: float | None
    drop_hi: float | None
    drop_worlds_lo: float | None = None
    drop_worlds_hi: float | None = None
    explained: float | None = None


#: The columns of ``attribution.csv``, in order.
FIELDS = tuple(f.name for f in fields(AttributionRow))

#: Draws and seed of the world bootstrap (the study's documented protocol, see ``drop_bootstrap``).
BOOT_DRAWS, BOOT_SEED = 2000, 0


def check_seeds(seeds: list[int], field: str = "seeds") -> list[int]:
    """``seeds`` as given, after checking there is at least one, none negative and none twice."""
    if not seeds:
        raise ConfigError(f"{field}: empty (allowed: one or more world seeds >= 0, e.g. 0,1,2,3)")
    for s in seeds:
        if s < 0:
            raise ConfigError(f"{field}: {s} is negative (allowed: world seeds >= 0)")
    dup = sorted({s for s in seeds if seeds.count(s) > 1})
    if dup:
        raise ConfigError(f"{field}: {', '.join(map(str, dup))} named twice (each world seed once)")
    return list(seeds)


def parse_seeds(text: str, field: str = "seeds") -> list[int]:
    """``"0,1,2"`` -> ``[0, 1, 2]`` (checked by ``check_seeds``; ``ConfigError`` naming ``field``)."""
    items = [t.strip() for t in text.split(",")]
    if not any(items):
        return check_seeds([], field)
    out = []
    for t in items:
        try:
            out.append(int(t))
        except ValueError:
            raise ConfigError(
                f"{field}: {t!r} is not a whole number (allowed: world seeds >= 0, e.g. 0,1,2,3)"
            ) from None
    return check_seeds(out, field)


class AttributionConfig(StrictModel):
    """What the study runs: two scenarios, the mechanisms switched off in turn, the methods scored."""

    same: str = Field("same_direction", min_length=1)
    opposite: str = Field("opposite_direction", min_length=1)
    mechanisms: list[str] = Field(default_factory=lambda: list(DEFAULT_MECHANISMS))
    methods: list[str] = Field(default_factory=lambda: ["roman", "ransac1m"], min_length=1)
    overrides: list[str] = Field(default_factory=lambda: list(STUDY_OVERRIDES), description="--set items, every run")
    seeds: list[int] | None = Field(
        None, description="world seeds, each run in every one (None: the scenarios' own world, once)"
    )
    level: float = Field(0.95, gt=0, lt=1, description="confidence level of the intervals")
    boot_draws: int = Field(BOOT_DRAWS, ge=1, description="draws of the world bootstrap")
    boot_seed: int = Field(BOOT_SEED, ge=0, description="seed of the world bootstrap's draws")
    executor: ExecutorConfig = Field(
        default_factory=lambda: ExecutorConfig(kind="local"), description="how each run spreads its robots and pairs"
    )

    @field_validator("seeds")
    @classmethod
    def _seeds(cls, v: list[int] | None) -> list[int] | None:
        if v is not None:
            try:
                check_seeds(v, "seeds")
            except ConfigError as err:
                raise ValueError(str(err).split(": ", 1)[1]) from None
        return v


@dataclass(frozen=True)
class StudyRun:
    """One run of the study: its role (same or opposite), scenario, mechanism switched off, world
    seed (None: the scenario's own) and folder."""

    role: str
    scenario: str
    mechanism: str
    name: str
    overrides: tuple[str, ...]
    seed: int | None = None


@dataclass(frozen=True)
class PlannedRun:
    """A run as ``attribution.json`` lists it: role, scenario, mechanism switched off, folder,
    overrides and world seed (None: the scenario's own)."""

    role: str
    scenario: str
    mechanism: str
    run: str
    overrides: list[str]
    seed: int | None = None


@dataclass(frozen=True)
class AttributionPlan:
    """``attribution.json``: the study's configuration and its runs."""

    config: AttributionConfig
    runs: list[PlannedRun]


def run_name(role: str, mechanism: str, seed: int | None) -> str:
    """A run's folder name: ``<role>__<mechanism>``, with ``__s<seed>`` when the study names worlds."""
    return f"{role}__{mechanism}" if seed is None else f"{role}__{mechanism}__s{seed}"


def plan_runs(cfg: AttributionConfig) -> list[StudyRun]:
    """Every run of the study, world by world, all-on first, with its overrides (checks the names)."""
    from roman_sim.core.overrides import apply_overrides
    from roman_sim.core.yamlio import read_yaml
    from roman_sim.pipeline.scenario import resolve_scenario_path

    check_mechanisms(cfg.mechanisms, "mechanisms")
    seeds: list[int | None] = [None] if cfg.seeds is None else list(check_seeds(cfg.seeds))
    runs = []
    for seed in seeds:  # world by world: a study stopped early holds whole worlds
        world = () if seed is None else (f"seed={seed}",)
        for role, scenario in zip(ROLES, (cfg.same, cfg.opposite)):
            data = apply_overrides(read_yaml(resolve_scenario_path(scenario)), [*cfg.overrides, *world])
            for mech in (ALL_ON, *cfg.mechanisms):
                ovr = (*cfg.overrides, *world, f"aligners=[{', '.join(cfg.methods)}]", *mechanism_overrides(mech, data))
                runs.append(StudyRun(role, scenario, mech, run_name(role, mech, seed), ovr, seed))
    return runs


def _done(run_dir: Path, scenario: Any) -> bool:
    """Whether ``run_dir`` holds a complete run of exactly ``scenario`` (resolved) with the current code."""
    from roman_sim.pipeline.experiment import is_current_run

    return is_current_run(run_dir, scenario)


def run_study(cfg: AttributionConfig, out: Path, on_run: Callable[[int, int, str, bool], None] | None = None) -> None:
    """Run (or resume) every run of the study under ``out/runs`` (``on_run(i, n, name, reused)`` after each)."""
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    runs = plan_runs(cfg)
    scenarios = [load_scenario(r.scenario, list(r.overrides)) for r in runs]  # every switch validated up front
    out.mkdir(parents=True, exist_ok=True)
    plan = AttributionPlan(
        cfg.model_copy(deep=True),
        [PlannedRun(r.role, r.scenario, r.mechanism, r.name, list(r.overrides), r.seed) for r in runs],
    )
    write_record(out / PLAN, plan, SCHEMA)
    for i, (r, sc) in enumerate(zip(runs, scenarios)):
        run_dir = out / "runs" / r.name
        reused = _done(run_dir, sc)
        if not reused:
            log.info("attribution: %s (%d/%d)", r.name, i + 1, len(runs))
            Experiment(sc, run_dir, executor=cfg.executor).run()
        if on_run is not None:
            on_run(i + 1, len(runs), r.name, reused)


@dataclass(frozen=True)
class Cell:
    """One method's max recall in one run: hits, relevant pairs, false positives at that point."""

    hits: int
    relevant: int
    false_positives: int


def run_cells(run_dir: Path, methods: list[str]) -> dict[str, Cell]:
    """Max-recall counts of ``methods`` over the cross-robot pairs of a finished run."""
    from roman_sim.pipeline.result import RunResult

    metrics = RunResult.load(run_dir).metrics
    out = {}
    for m in methods:
        pt = metrics.stats(m, kind="inter").operating_points.get("max_recall")
        if pt is None:
            raise StorageError(f"{run_dir}: no max-recall point for {m} (was the method run?)")
        out[m] = Cell(pt.hits, pt.n_relevant, pt.false_positives)
    return out


def newcombe(k1: int, n1: int, k2: int, n2: int, level: float) -> tuple[float, float] | None:
    """Newcombe's hybrid-score interval of ``k1/n1 - k2/n2`` (independent samples); None without pairs."""
    w1, w2 = wilson(k1, n1, level), wilson(k2, n2, level)
    if w1 is None or w2 is None:
        return None
    p1, p2 = k1 / n1, k2 / n2
    d = p1 - p2
    return (d - math.hypot(p1 - w1[0], w2[1] - p2), d + math.hypot(w1[1] - p1, p2 - w2[0]))


def _ratio(k: int, n: int) -> float | None:
    return k / n if n else None


def bootstrap_draws(n_worlds: int, draws: int = BOOT_DRAWS, seed: int = BOOT_SEED) -> NDArray[np.int64]:
    """The world bootstrap's resamples: a (draws, n_worlds) table of world indices drawn with
    replacement, ``numpy.random.default_rng(seed).integers(0, n_worlds, (draws, n_worlds))``."""
    return np.random.default_rng(seed).integers(0, n_worlds, (draws, n_worlds))


def drop_bootstrap(
    same: list[tuple[int, int]], opposite: list[tuple[int, int]], draws: NDArray[np.int64], level: float
) -> tuple[float, float] | None:
    """Percentile interval of the pooled drop over resampled worlds.

    ``same[w]`` and ``opposite[w]`` are world ``w``'s (hits, relevant) in each direction; each row
    of ``draws`` is one resample of world indices (a world drawn twice counts twice, in both
    directions). A resample's drop is ``sum hits_same / sum relevant_same - sum hits_opp / sum
    relevant_opp`` over its worlds; resamples with no relevant pair in a direction are left
    out; the interval is the ``(1 - level) / 2`` and ``(1 + level) / 2`` quantiles of the rest
    (numpy's linear rule). None when every resample is left out.
    """
    s, o = np.asarray(same, dtype=np.float64), np.asarray(opposite, dtype=np.float64)
    hs, ns, ho, no = (a[draws].sum(axis=1) for a in (s[:, 0], s[:, 1], o[:, 0], o[:, 1]))
    ok = (ns > 0) & (no > 0)
    if not ok.any():
        return None
    d = hs[ok] / ns[ok] - ho[ok] / no[ok]
    tail = (1 - level) / 2
    return float(np.quantile(d, tail)), float(np.quantile(d, 1 - tail))


def pool(cells: list[Cell]) -> Cell:
    """The worlds' cells summed: pooled hits, relevant pairs and false positives."""
    return Cell(sum(c.hits for c in cells), sum(c.relevant for c in cells), sum(c.false_positives for c in cells))


def table_rows(
    cells: dict[tuple[str, str, int | None], dict[str, Cell]], cfg: AttributionConfig
) -> list[AttributionRow]:
    """The attribution table from ``cells[(role, mechanism, seed)][method]`` (see the module docstring)."""
    seeds: list[int | None] = [None] if cfg.seeds is None else [*sorted(cfg.seeds)]
    draws = bootstrap_draws(len(seeds), cfg.boot_draws, cfg.boot_seed) if len(seeds) >= 2 else None
    rows = []
    for mech in (ALL_ON, *cfg.mechanisms):
        for m in cfg.methods:
            row: dict[str, Any] = {"mechanism": mech, "method": m, "worlds": len(seeds)}
            per_world = {role: [cells[(role, mech, w)][m] for w in seeds] for role in ROLES}
            for role in ROLES:
                c = pool(per_world[role])
                ci = wilson(c.hits, c.relevant, cfg.level)
                row |= {
                    f"{role}_hits": c.hits,
                    f"{role}_relevant": c.relevant,
                    f"{role}_recall": _ratio(c.hits, c.relevant),
                    f"{role}_recall_lo": None if ci is None else ci[0],
                    f"{role}_recall_hi": None if ci is None else ci[1],
                    f"{role}_precision": _ratio(c.hits, c.hits + c.false_positives),
                }
            s, o = pool(per_world["same"]), pool(per_world["opposite"])
            nc = newcombe(s.hits, s.relevant, o.hits, o.relevant, cfg.level)
            row["drop"] = None if nc is None else s.hits / s.relevant - o.hits / o.relevant
            row["drop_lo"], row["drop_hi"] = (None, None) if nc is None else nc
            boot = None
            if draws is not None and nc is not None:
                counts = {role: [(c.hits, c.relevant) for c in per_world[role]] for role in ROLES}
                boot = drop_bootstrap(counts["same"], counts["opposite"], draws, cfg.level)
            row["drop_worlds_lo"], row["drop_worlds_hi"] = (None, None) if boot is None else boot
            rows.append(AttributionRow(**row))
    base = {r.method: r.drop for r in rows if r.mechanism == ALL_ON}
    for r in rows:
        b = base[r.method]
        r.explained = None if b is None or r.drop is None or b <= 0 else (b - r.drop) / b
    return rows


def _cell(v: object) -> object:
    return "" if v is None else (f"{v:.6f}" if isinstance(v, float) else v)


def write_table(rows: list[AttributionRow], out: Path) -> Path:
    """``attribution.csv`` (atomically; floats to 6 decimals, empty where undefined)."""
    from roman_sim.core.atomic import write_text

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(FIELDS), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: _cell(getattr(r, k)) for k in FIELDS})
    path = out / TABLE
    write_text(path, buf.getvalue())
    return path


def run_attribution(
    cfg: AttributionConfig, out: str | Path, on_run: Callable[[int, int, str, bool], None] | None = None
) -> list[AttributionRow]:
    """Run (or resume) the study in ``out``, write ``attribution.csv`` and return its rows."""
    out = Path(out)
    run_study(cfg, out, on_run)
    cells = {(r.role, r.mechanism, r.seed): run_cells(out / "runs" / r.name, cfg.methods) for r in plan_runs(cfg)}
    rows = table_rows(cells, cfg)
    write_table(rows, out)
    return rows


def collect_attribution(study: str | Path, dest: str | Path) -> Path:
    """Keep a finished study in ``dest``: its plan, table and, per run, the configuration, metrics and raw pairs."""
    import shutil

    from roman_sim.studies.reference import collect

    src, dst = Path(study), Path(dest)
    missing = [n for n in (PLAN, TABLE) if not (src / n).is_file()]
    if missing:
        raise ConfigError(f"{src}: not a finished attribution study (missing {', '.join(missing)})")
    if dst.resolve() == src.resolve():
        raise ConfigError(f"--results: {dst} is the study's own folder; name another one")
    if dst.is_dir():
        shutil.rmtree(dst)
    dst.mkdir(parents=True)
    for name in (PLAN, TABLE):
        shutil.copyfile(src / name, dst / name)
    for run in sorted(p for p in (src / "runs").iterdir() if (p / "pairs.csv").is_file()):
        collect(run, dst / "runs" / run.name, trajectories=False, plots=False, packets=False)
    return dst


#: Markers of the generated block on the heading-mechanisms page.
MARKERS = ("<!-- attribution:begin -->", "<!-- attribution:end -->")
PAGE = "docs/heading_mechanisms.md"
#: Shares of the all-on drop (point estimates) at and above which a mechanism dominates / contributes.
DOMINANT, CONTRIBUTES = 0.5, 0.2


def read_table(folder: str | Path) -> list[AttributionRow]:
    """``attribution.csv`` of a study folder, numbers parsed (None where empty).

    A table from before worlds were the unit (no ``worlds`` column) is one world's: ``worlds``
    reads 1 and the world-bootstrap columns None.
    """
    with open(Path(folder) / TABLE, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    out = []
    for r in rows:
        r = {"worlds": "1", "drop_worlds_lo": "", "drop_worlds_hi": "", **r}
        parsed: dict[str, Any] = {}
        for k, v in r.items():
            if k in ("mechanism", "method"):
                parsed[k] = v
            elif v == "":
                parsed[k] = None
            else:
                parsed[k] = int(v) if k.endswith(("_hits", "_relevant")) or k == "worlds" else float(v)
        out.append(AttributionRow(**parsed))
    return out


def classify(rows: list[AttributionRow], method: str) -> dict[str, list[str]]:
    """Mechanisms of ``method`` by the share of the all-on drop they explain (point estimates).

    ``dominant``: at least ``DOMINANT``; ``contributes``: at least ``CONTRIBUTES``; ``negligible``:
    less (a negative share, a larger drop with the mechanism off, included); ``undefined``: no
    all-on drop to explain.
    """
    out: dict[str, list[str]] = {"dominant": [], "contributes": [], "negligible": [], "undefined": []}
    for r in rows:
        if r.method != method or r.mechanism == ALL_ON:
            continue
        e = r.explained
        key = (
            "undefined"
            if e is None
            else "dominant"
            if e >= DOMINANT
            else "contributes"
            if e >= CONTRIBUTES
            else "negligible"
        )
        out[key].append(r.mechanism)
    return out


def drop_interval(r: AttributionRow) -> tuple[float, float, str] | None:
    """The interval a row's verdict uses: the world bootstrap's with two or more worlds, else Newcombe's."""
    if r.worlds >= 2:
        lo, hi, name = r.drop_worlds_lo, r.drop_worlds_hi, "world-bootstrap"
    else:
        lo, hi, name = r.drop_lo, r.drop_hi, "Newcombe"
    return None if lo is None or hi is None else (lo, hi, name)


def share_cell(r: AttributionRow) -> str:
    """The share of the all-on drop a row explains (``-`` for the all-on row itself)."""
    if r.mechanism == ALL_ON:
        return "-"
    return "n/a" if r.explained is None else f"{100 * r.explained:+.1f} %"


def _span(lo: float | None, hi: float | None) -> str:
    return "n/a" if lo is None or hi is None else f"[{lo:+.2f}, {hi:+.2f}]"


def recall_cell(r: AttributionRow, role: str, sep: str = ", ") -> str:
    """One role's (``same`` / ``opposite``) hits/relevant, recall [interval] and precision, from a table row."""
    keys = ("hits", "relevant", "recall", "recall_lo", "recall_hi", "precision")
    hits, rel, rec, lo, hi, p = (getattr(r, f"{role}_{k}") for k in keys)
    if rec is None:
        return "no relevant pair"
    return f"{hits}/{rel} = {rec:.2f} [{lo:.2f}, {hi:.2f}]{sep}P {'n/a' if p is None else f'{p:.2f}'}"


def _separated(r: AttributionRow) -> bool:
    """Whether a row's drop is above 0 by the interval its verdict uses (``drop_interval``)."""
    ci = drop_interval(r)
    return ci is not None and ci[0] > 0


def _verdict(r: AttributionRow) -> str:
    """``its <kind> interval [lo, hi] excludes / includes 0`` for a row's drop."""
    ci = drop_interval(r)
    if ci is None:
        return "no interval"
    lo, hi, kind = ci
    return f"its {kind} interval {_span(lo, hi)} {'excludes' if lo > 0 or hi < 0 else 'includes'} 0"


def attribution_block(folder: str | Path) -> str:
    """The page's generated block (markers included) from a kept study's ``attribution.csv``."""
    rows = read_table(folder)
    begin, end = MARKERS
    worlds = rows[0].worlds if rows else 1
    head = (
        f"Counts pooled over {worlds} worlds (each world's max-recall point, summed); the verdicts below "
        "use the world-bootstrap intervals."
        if worlds >= 2
        else "One world: no world-bootstrap interval (it needs two or more); the verdicts below use Newcombe's."
    )
    lines = [
        begin,
        head,
        "",
        "| mechanism off | method | same direction | opposite direction | drop [95 % Newcombe] "
        "| drop [95 % world bootstrap] | share of the all-on drop |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        drop = "n/a" if r.drop is None else f"{r.drop:+.2f} {_span(r.drop_lo, r.drop_hi)}"
        boot = _span(r.drop_worlds_lo, r.drop_worlds_hi)
        lines.append(
            f"| `{r.mechanism}` | {r.method} | {recall_cell(r, 'same')} | {recall_cell(r, 'opposite')} "
            f"| {drop} | {boot} | {share_cell(r)} |"
        )
    lines.append("")
    for method in dict.fromkeys(r.method for r in rows):
        base = next(r for r in rows if r.method == method and r.mechanism == ALL_ON)
        c = classify(rows, method)
        named = {k: ", ".join(f"`{m}`" for m in v) or "none" for k, v in c.items()}
        drop = "n/a" if base.drop is None else f"{base.drop:+.2f}"
        sig = _verdict(base)
        lines.append(
            f"- {method}: all-on drop {drop} ({sig}). Dominant (share >= {DOMINANT:.0%}): {named['dominant']}; "
            f"contributing ({CONTRIBUTES:.0%} to {DOMINANT:.0%}): {named['contributes']}; "
            f"negligible (< {CONTRIBUTES:.0%}): {named['negligible']}."
        )
        for r in rows:
            if r.method == method and r.mechanism == "descriptor_view" and r.drop is not None:
                verdict = "it does not vanish" if _separated(r) else _verdict(r)
                lines.append(f"  With `descriptor_view` off the drop is {r.drop:+.2f} ({verdict}).")
    lines.append(end)
    return "\n".join(lines)
