"""The ``paper`` front-end preset fitted to ONE figure of the paper, then its held-out predictions.

Fit (``fit_paper_preset``): one scalar, ``frontend.severity``, scales the preset's error
parameters (``roman_sim.frontend.presets``). It is searched on ``scenario``
(``same_direction``) for ROMAN's max recall over the cross-robot pairs to match the paper's
0.67, and nothing else is tuned:

1. every severity of ``grid`` is run (in order);
2. where the recall crosses the target between two neighbouring grid severities, the bracket
   is bisected ``refine`` times (the recall falls as the severity grows); without a crossing
   the search stops at the grid;
3. the fitted severity is the run one whose recall lies closest to the target (a figure that
   was measured, not interpolated).

Every run's figures are saved in ``fit_state.json`` as soon as it ends (atomically), with the
fit's configuration: a second call with the same configuration reuses them, so an interrupted
fit resumes; another configuration is refused. The result, ``paper_fit.yaml``, is a
front-end preset file: the preset's parameters at the fitted severity (``frontend``, usable as
``frontend.preset: paper_fit.yaml``) and the ``fit`` (target, figure, severity, search).

Predictions (``predict_paper_preset``): ``predict_scenario`` (``opposite_direction``) is run
with the fitted preset, and ``paper_predictions.json`` states three claims, each holding or
not: ROMAN's opposite-direction max recall within 0.26 +- 0.08; the ordering ROMAN >
RANSAC-1M > CLIPPER there (max recall); the same/opposite ratio of ROMAN's max recall within
the band that the +- 0.08 gives around the paper's 2.6 (0.67 / 0.34 to 0.67 / 0.18).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from pydantic import Field, field_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError
from roman_sim.core.records import RecordError, read_record, write_record

log = logging.getLogger(__name__)

#: The paper's figures: the fitted one and the held-out ones.
PAPER_SAME_RECALL = 0.67
PAPER_OPPOSITE_RECALL = 0.26
PAPER_OPPOSITE_BAND = 0.08
PAPER_RATIO = 2.6
STATE, FIT_YAML, PREDICTIONS = "fit_state.json", "paper_fit.yaml", "paper_predictions.json"

#: ``run(scenario, overrides, run_dir) -> {method: max recall}`` over the cross-robot pairs.
RunFn = Callable[[str, list[str], Path], dict[str, float | None]]


class PaperFitConfig(StrictModel):
    """What the fit searches and where (see the module docstring)."""

    scenario: str = Field("same_direction", min_length=1)
    predict_scenario: str = Field("opposite_direction", min_length=1)
    preset: str = Field("paper", min_length=1)
    method: str = Field("roman", min_length=1)
    target: float = Field(PAPER_SAME_RECALL, gt=0, le=1)
    grid: list[float] = Field(default_factory=lambda: [0.0, 0.5, 1.0, 1.5, 2.0, 3.0])
    refine: int = Field(3, ge=0, le=10)
    tolerance: float = Field(0.01, ge=0, le=1, description="stop refining once a run is this close to the target")
    overrides: list[str] = Field(default_factory=list, description="--set items for every run (e.g. shorter paths)")
    fit_aligners: list[str] = Field(default_factory=lambda: ["roman"], min_length=1)
    predict_aligners: list[str] = Field(default_factory=lambda: ["roman", "ransac1m", "clipper"], min_length=1)

    @field_validator("grid")
    @classmethod
    def _grid(cls, v: list[float]) -> list[float]:
        if len(v) < 2 or any(b <= a for a, b in zip(v, v[1:])) or v[0] < 0 or v[-1] > 10:
            raise ValueError("needs at least two increasing severities within [0, 10]")
        return v

    def run_overrides(self, severity: float, fitted_preset: str | None = None) -> list[str]:
        """The ``--set`` items of one fit run at ``severity``, or of the prediction run with ``fitted_preset``.

        Only the aligners the figures need run (``fit_aligners``, ``predict_aligners``).
        """
        aligners = self.fit_aligners if fitted_preset is None else self.predict_aligners
        return [
            *self.overrides,
            f"aligners=[{', '.join(aligners)}]",
            f"frontend.preset={fitted_preset or self.preset}",
            f"frontend.severity={severity:g}",
        ]


def _key(severity: float) -> str:
    return f"{severity:.6f}"


@dataclass(frozen=True)
class FitStateRecord:
    """``fit_state.json``: the fit's configuration and, per severity, each method's max recall."""

    config: dict[str, Any]
    runs: dict[str, dict[str, float | None]]


class FitState:
    """The runs done so far, keyed by severity, saved after each run (``fit_state.json``)."""

    def __init__(self, out: Path, cfg: PaperFitConfig) -> None:
        self.path = out / STATE
        self.cfg = cfg
        self.runs: dict[str, dict[str, float | None]] = {}
        if self.path.is_file():
            try:
                saved = read_record(self.path, FitStateRecord)
            except RecordError as err:
                raise ConfigError(f"{err} (not a paper-fit state file; remove it to start again)") from None
            if saved.config != cfg.model_dump(mode="json"):
                raise ConfigError(
                    f"{self.path}: made with another fit configuration; use another output folder or remove it"
                )
            self.runs = {k: dict(v) for k, v in saved.runs.items()}

    def save(self) -> None:
        """Write the state atomically."""
        write_record(self.path, FitStateRecord(self.cfg.model_dump(mode="json"), self.runs))

    def recall(self, severity: float) -> float | None:
        """The fitted method's max recall at ``severity`` (None when the run had no relevant pair)."""
        return self.runs[_key(severity)].get(self.cfg.method)


def default_run(scenario: str, overrides: list[str], run_dir: Path) -> dict[str, float | None]:
    """Run ``scenario`` with ``overrides`` in ``run_dir`` (resuming its finished stages); max recall per method."""
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    sc = load_scenario(scenario, overrides)
    res = Experiment(sc, run_dir).run()
    return {m: res.metrics.stats(m, kind="inter").max_recall for m in res.metrics.methods}


def _evaluate(state: FitState, severity: float, out: Path, run: RunFn) -> float | None:
    key = _key(severity)
    if key not in state.runs:
        cfg = state.cfg
        log.info("paper fit: %s at severity %g", cfg.scenario, severity)
        state.runs[key] = run(cfg.scenario, cfg.run_overrides(severity), out / "runs" / f"{cfg.scenario}_{key}")
        state.save()
    return state.recall(severity)


def _search(state: FitState, out: Path, run: RunFn) -> None:
    """Grid, then bisection of the first bracket where the recall crosses the target."""
    cfg = state.cfg
    got = [(s, _evaluate(state, s, out, run)) for s in cfg.grid]
    if any(r is not None and abs(r - cfg.target) <= cfg.tolerance for _, r in got):
        return
    bracket = next(
        (
            (a, b)
            for (a, ra), (b, rb) in zip(got, got[1:])
            if ra is not None and rb is not None and rb <= cfg.target <= ra
        ),
        None,
    )
    if bracket is None:
        log.warning("paper fit: the grid does not bracket the target %.3f (recalls %s)", cfg.target, got)
        return
    lo, hi = bracket
    for _ in range(cfg.refine):
        mid = 0.5 * (lo + hi)
        r = _evaluate(state, mid, out, run)
        if r is None:
            break
        if abs(r - cfg.target) <= cfg.tolerance:
            return
        lo, hi = (mid, hi) if r > cfg.target else (lo, mid)


def fit_paper_preset(out: str | Path, cfg: PaperFitConfig | None = None, run: RunFn | None = None) -> dict[str, Any]:
    """Fit the severity (see the module docstring); write ``paper_fit.yaml`` in ``out``; return its content."""
    from roman_sim.core.atomic import write_text

    cfg = cfg or PaperFitConfig()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    state = FitState(out, cfg)
    _search(state, out, run or default_run)
    done = sorted((float(k), v.get(cfg.method)) for k, v in state.runs.items())
    scored = [(s, r) for s, r in done if r is not None]
    if not scored:
        raise ConfigError(f"paper fit: no run of {cfg.scenario} had relevant pairs for {cfg.method}")
    severity, recall = min(scored, key=lambda sr: (abs(sr[1] - cfg.target), sr[0]))
    result = {
        "fit": {
            "figure": f"{cfg.method} max recall, cross-robot pairs, {cfg.scenario}",
            "paper": cfg.target,
            "fitted": recall,
            "severity": severity,
            "preset": cfg.preset,
            "searched": [[s, r] for s, r in done],
            "config": cfg.model_dump(mode="json"),
        },
        "frontend": preset_at(cfg.preset, severity),
    }
    write_text(out / FIT_YAML, yaml.safe_dump(result, sort_keys=False))
    return result


def preset_at(preset: str, severity: float) -> dict[str, Any]:
    """The preset's ``frontend`` section with its error parameters at ``severity`` (explicit values)."""
    from roman_sim.core.config import validate_model
    from roman_sim.frontend.components import FrontEndConfig

    fe = validate_model(FrontEndConfig, {"preset": preset, "severity": severity}, source="frontend")
    seg = fe.built_segmenter()
    out: dict[str, Any] = {
        "segmenter": {"name": seg.name, "params": dict(seg.params)},
        "semantics": fe.built_semantics().model_dump(mode="json"),
    }
    if fe.encoder.name != "simulated" or fe.encoder.params:
        out["encoder"] = fe.encoder.model_dump(mode="json")
    return out


@dataclass(frozen=True)
class PaperClaim:
    """One held-out prediction: the paper's claim, its figure, the simulated value, whether it holds."""

    claim: str
    paper: float | str
    value: float | dict[str, float | None] | None
    holds: bool

    def shown(self) -> str:
        """The simulated value as a table shows it (per method when several)."""
        v = self.value
        return ", ".join(f"{k} {_fmt(x)}" for k, x in v.items()) if isinstance(v, dict) else _fmt(v)


@dataclass(frozen=True)
class FittedFigure:
    """The one figure the preset was fitted on: scenario, name, the paper's value and the fitted one."""

    scenario: str
    figure: str
    paper: float
    value: float


@dataclass(frozen=True)
class PaperPredictions:
    """``paper_predictions.json``: the fitted severity and figure, the held-out run's max recalls, the claims."""

    severity: float
    fitted: FittedFigure
    scenario: str
    max_recall: dict[str, float | None]
    claims: list[PaperClaim]


def read_predictions(path: str | Path) -> PaperPredictions:
    """``paper_predictions.json`` (RecordError naming the file and field when malformed)."""
    return read_record(path, PaperPredictions)


def predict_paper_preset(
    out: str | Path, cfg: PaperFitConfig | None = None, run: RunFn | None = None
) -> PaperPredictions:
    """Run ``predict_scenario`` with the fitted preset; write ``paper_predictions.json``; return it."""
    from roman_sim.core.config import read_yaml

    out = Path(out)
    fit_file = out / FIT_YAML
    if not fit_file.is_file():
        raise ConfigError(f"{fit_file}: file not found (run the fit first: roman-sim paper-preset fit --out {out})")
    fit = read_yaml(fit_file)["fit"]
    cfg = cfg or PaperFitConfig(**fit["config"])
    run = run or default_run
    got = run(
        cfg.predict_scenario, cfg.run_overrides(1.0, str(fit_file.resolve())), out / "runs" / cfg.predict_scenario
    )
    same = float(fit["fitted"])
    roman, ransac, clipper = (got.get(m) for m in (cfg.method, "ransac1m", "clipper"))
    lo, hi = PAPER_OPPOSITE_RECALL - PAPER_OPPOSITE_BAND, PAPER_OPPOSITE_RECALL + PAPER_OPPOSITE_BAND
    ratio = same / roman if roman else None
    ratio_lo, ratio_hi = PAPER_SAME_RECALL / hi, PAPER_SAME_RECALL / lo
    band = f"{PAPER_OPPOSITE_RECALL} +- {PAPER_OPPOSITE_BAND}"
    claims = [
        PaperClaim(
            f"ROMAN's opposite-direction max recall lies within {band}",
            PAPER_OPPOSITE_RECALL,
            roman,
            roman is not None and lo <= roman <= hi,
        ),
        PaperClaim(
            "opposite direction: ROMAN > RANSAC-1M > CLIPPER (max recall)",
            "ROMAN > RANSAC-1M > CLIPPER",
            {"roman": roman, "ransac1m": ransac, "clipper": clipper},
            None not in (roman, ransac, clipper) and roman > ransac > clipper,  # type: ignore[operator]
        ),
        PaperClaim(
            f"same/opposite ratio of ROMAN's max recall within {ratio_lo:.2f}-{ratio_hi:.2f}",
            PAPER_RATIO,
            ratio,
            ratio is not None and ratio_lo <= ratio <= ratio_hi,
        ),
    ]
    result = PaperPredictions(
        severity=fit["severity"],
        fitted=FittedFigure(cfg.scenario, fit["figure"], fit["paper"], same),
        scenario=cfg.predict_scenario,
        max_recall=dict(got),
        claims=claims,
    )
    write_record(out / PREDICTIONS, result)
    return result


#: The fit's folder inside the reference results.
PAPER_PRESET_DIR = "paper_preset"
#: The generated block of the results page.
PRESET_MARKERS = ("<!-- paper-preset:begin -->", "<!-- paper-preset:end -->")


def collect_paper_preset(fit_dir: str | Path, dest: str | Path) -> Path:
    """Copy a finished fit and its predictions into ``dest`` (the reference results' ``paper_preset/``).

    Kept: ``fit_state.json``, ``paper_fit.yaml``, ``paper_predictions.json`` and, per run (every
    fit run and the prediction run, under ``runs/<name>/``), what ``reference.collect`` keeps
    without plots, trajectories or packets: the metrics, configuration and the raw pairs
    (``pairs.csv.gz``, ``alignments.json.gz``), from which every figure is re-derived.
    """
    import shutil

    from roman_sim.studies.reference import collect

    src, out = Path(fit_dir), Path(dest)
    missing = [n for n in (STATE, FIT_YAML, PREDICTIONS) if not (src / n).is_file()]
    if missing:
        raise ConfigError(f"{src}: not a finished fit with predictions (missing {', '.join(missing)})")
    if out.is_dir():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    for name in (STATE, FIT_YAML, PREDICTIONS):
        shutil.copyfile(src / name, out / name)
    for run in sorted(p for p in (src / "runs").iterdir() if (p / "pairs.csv").is_file()):
        collect(run, out / "runs" / run.name, trajectories=False, plots=False, packets=False)
    return out


def _fmt(v: Any) -> str:
    return "n/a" if v is None else f"{float(v):.2f}"


def preset_block(folder: str | Path) -> str:
    """The results page's paper-preset block (markers included), from a collected fit's JSON and YAML."""

    from roman_sim.core.config import read_yaml

    d = Path(folder)
    fit = read_yaml(d / FIT_YAML)["fit"]
    pred = read_predictions(d / PREDICTIONS)
    begin, end = PRESET_MARKERS
    lines = [
        begin,
        f"Fitted on one figure only: {fit['figure']} (paper {fit['paper']:.2f}), through the severity "
        f"of the `{fit['preset']}` preset. Fitted severity {fit['severity']:g}: {_fmt(fit['fitted'])}.",
        "",
        "| severity | " + fit["figure"] + " |",
        "|---|---|",
        *(
            f"| {s:g}{' (fitted)' if s == fit['severity'] else ''} | {_fmt(r)} |"
            for s, r in (tuple(x) for x in fit["searched"])
        ),
        "",
        f"Held-out predictions on `{pred.scenario}` at that severity, nothing else changed (cross-robot max recall):",
        "",
        "| prediction | paper | simulated | holds |",
        "|---|---|---|---|",
    ]
    for c in pred.claims:
        lines.append(f"| {c.claim} | {c.paper} | {c.shown()} | {'yes' if c.holds else 'no'} |")
    return "\n".join([*lines, end])
