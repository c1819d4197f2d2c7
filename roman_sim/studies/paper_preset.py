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

The fit's own uncertainty: each run's recall is a binomial count, hits out of relevant
cross-robot pairs. The ADMITTED settings are every run severity whose recall's 95 % Wilson
score interval (``roman_sim.evaluation.intervals.wilson``) contains the target, and the
fitted severity always: the settings the measured figure cannot tell apart from the paper's.

Every run's counts are saved in ``fit_state.json`` as soon as it ends (atomically), with the
fit's configuration: a second call with the same configuration reuses them, so an interrupted
fit resumes; another configuration is refused. The result, ``paper_fit.yaml``, is a
front-end preset file: the preset's parameters at the fitted severity (``frontend``, usable as
``frontend.preset: paper_fit.yaml``) and the ``fit`` (target, figure, severity, every run with
its interval, the admitted severities).

Predictions (``predict_paper_preset``): ``predict_scenario`` (``opposite_direction``) is run
with the preset at every admitted severity (``runs/<predict_scenario>_<severity>``; each run's
counts saved in ``fit_state.json`` as soon as it ends, so an interrupted prediction resumes),
and ``paper_predictions.json`` states three claims: ROMAN's opposite-direction max recall
within 0.26 +- 0.08; the ordering ROMAN > RANSAC-1M > CLIPPER there (max recall); the
same/opposite ratio of ROMAN's max recall (both at the same severity) within the band that the
+- 0.08 gives around the paper's 2.6 (0.67 / 0.34 to 0.67 / 0.18). Each claim gives every
admitted setting's value with its Wilson interval(s), the range (min, max) over the settings
run, and a verdict: it holds for ``every`` admitted setting, for ``some``, for ``none``, or
``undetermined`` when settings were not run and those that were all agree.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import Field, field_validator

from roman_sim.core.config import StrictModel
from roman_sim.core.errors import ConfigError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import OMIT_NONE, RecordError, from_json, read_json, read_record, to_json, write_record

log = logging.getLogger(__name__)

#: The paper's figures: the fitted one and the held-out ones.
PAPER_SAME_RECALL = 0.67
PAPER_OPPOSITE_RECALL = 0.26
PAPER_OPPOSITE_BAND = 0.08
PAPER_RATIO = 2.6
#: The level of the Wilson intervals that decide which settings the target admits.
ADMIT_LEVEL = 0.95
#: The methods of the ordering claim, best first.
ORDERING = ("roman", "ransac1m", "clipper")
STATE, FIT_YAML, PREDICTIONS = "fit_state.json", "paper_fit.yaml", "paper_predictions.json"
#: The verdicts of a claim over the admitted settings.
VERDICTS = ("every", "some", "none", "undetermined")

#: ``run(scenario, overrides, run_dir) -> {method: (max hits, relevant pairs)}`` over the
#: cross-robot pairs (max recall = hits / relevant).
RunFn = Callable[[str, list[str], Path], dict[str, tuple[int, int]]]


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
    predict_aligners: list[str] = Field(default_factory=lambda: list(ORDERING), min_length=1)

    @field_validator("grid")
    @classmethod
    def _grid(cls, v: list[float]) -> list[float]:
        if len(v) < 2 or any(b <= a for a, b in zip(v, v[1:])) or v[0] < 0 or v[-1] > 10:
            raise ValueError("needs at least two increasing severities within [0, 10]")
        return v

    def run_overrides(self, severity: float, predict: bool = False) -> list[str]:
        """The ``--set`` items of one run of the preset at ``severity``: a fit run, or a prediction run.

        Only the aligners the figures need run (``fit_aligners``, ``predict_aligners``).
        """
        aligners = self.predict_aligners if predict else self.fit_aligners
        return [
            *self.overrides,
            f"aligners=[{', '.join(aligners)}]",
            f"frontend.preset={self.preset}",
            f"frontend.severity={severity:g}",
        ]


@dataclass(frozen=True)
class Counts:
    """One method's max recall in one run as the count it is: ``hits`` of ``relevant`` pairs."""

    hits: int
    relevant: int

    @property
    def recall(self) -> float | None:
        """hits / relevant (None without a relevant pair)."""
        return self.hits / self.relevant if self.relevant else None

    @property
    def ci(self) -> tuple[float, float] | None:
        """The 95 % Wilson interval of the recall (None without a relevant pair)."""
        from roman_sim.evaluation.intervals import wilson

        return wilson(self.hits, self.relevant, ADMIT_LEVEL)

    def measure(self) -> Measure:
        """Counts, recall and interval, as the predictions file keeps them."""
        return Measure(self.hits, self.relevant, self.recall, self.ci)


@dataclass(frozen=True)
class Measure:
    """A max recall in ``paper_predictions.json``: hits, relevant pairs, recall, 95 % Wilson interval."""

    hits: int
    relevant: int
    max_recall: float | None
    ci: tuple[float, float] | None


@dataclass(frozen=True)
class PredictedRun:
    """One prediction run in ``fit_state.json``: its folder under ``runs/`` and each method's counts."""

    run: str
    figures: dict[str, Counts]


@dataclass(frozen=True)
class FitStateRecord:
    """``fit_state.json``: the fit's configuration; per severity each method's max recall (``runs``)
    and its counts (``counts``); the prediction runs by severity (``predicted``).

    ``counts`` and ``predicted`` are absent from a file made before the fit's uncertainty.
    """

    config: PaperFitConfig
    runs: dict[str, dict[str, float | None]]
    counts: dict[str, dict[str, Counts]] | None = field(default=None, metadata=OMIT_NONE)
    predicted: dict[str, PredictedRun] | None = field(default=None, metadata=OMIT_NONE)


def _key(severity: float) -> str:
    return f"{severity:.6f}"


def _counts_from_metrics(run_dir: Path, method: str) -> Counts | None:
    """A method's cross-robot (max hits, relevant pairs) from a finished run's ``metrics.json``, if it has them."""
    try:  # only the two figures are read (a folder of that time may hold no more)
        inter = read_json(run_dir / "metrics.json")["methods"][method]["inter"]
        return Counts(int(inter["max_hits"]), int(inter["n_relevant"]))
    except (RecordError, KeyError, TypeError, ValueError):
        return None


def _legacy_counts(recall: float | None, run_dir: Path, method: str, where: str) -> Counts:
    """A bare recall (a state file made before the counts) as counts, read back from its run's ``metrics.json``."""
    got = _counts_from_metrics(run_dir, method)
    if got is not None and (
        got.recall is None if recall is None else got.recall is not None and abs(got.recall - recall) < 1e-12
    ):
        return got
    raise ConfigError(
        f"{where}: saved without hit and relevant-pair counts (made before the fit's uncertainty) and "
        f"{run_dir / 'metrics.json'} does not give them; regenerate the fit in a new folder"
    )


class FitState:
    """The runs done so far, keyed by severity, saved after each run (``fit_state.json``).

    ``runs``: the fit's runs (``scenario``); ``predicted``: the prediction runs
    (``predict_scenario``), each with the name of its run folder under ``runs/``. A state file
    that predates the counts (bare recalls) is read back through each run folder's
    ``metrics.json``; its one prediction run (``runs/<predict_scenario>``, at the fitted
    severity, as ``paper_predictions.json`` says) likewise.
    """

    def __init__(self, out: Path, cfg: PaperFitConfig) -> None:
        self.out = out
        self.path = out / STATE
        self.cfg = cfg
        self.runs: dict[str, dict[str, Counts]] = {}
        self.predicted: dict[str, PredictedRun] = {}
        if not self.path.is_file():
            return
        try:
            saved = read_record(self.path, FitStateRecord)
        except RecordError as err:
            raise ConfigError(f"{err} (not a paper-fit state file; remove it to start again)") from None
        if saved.config != cfg:
            raise ConfigError(
                f"{self.path}: made with another fit configuration; use another output folder or remove it"
            )
        counts = saved.counts or {}
        for k, recalls in saved.runs.items():
            run_dir = out / "runs" / f"{cfg.scenario}_{k}"
            have = counts.get(k, {})
            self.runs[k] = {
                m: have[m] if m in have else _legacy_counts(r, run_dir, m, f"{self.path}: runs.{k}.{m}")
                for m, r in recalls.items()
            }
        if saved.predicted is None:
            self._adopt_single_prediction()
        else:
            self.predicted = dict(saved.predicted)

    def _adopt_single_prediction(self) -> None:
        """A folder from before the admitted settings ran one prediction, at the fitted severity."""
        old, run_dir = self.out / PREDICTIONS, self.out / "runs" / self.cfg.predict_scenario
        try:  # the file of that time: only its severity is read
            severity = float(read_json(old)["severity"])
        except (RecordError, KeyError, TypeError, ValueError):
            return
        got = {m: _counts_from_metrics(run_dir, m) for m in self.cfg.predict_aligners}
        figures = {m: v for m, v in got.items() if v is not None}
        if len(figures) == len(got):
            self.predicted[_key(severity)] = PredictedRun(run_dir.name, figures)
            log.info("paper fit: the prediction run %s counts as severity %g", run_dir, severity)

    def save(self) -> None:
        """Write the state atomically."""
        recalls = {k: {m: c.recall for m, c in v.items()} for k, v in self.runs.items()}
        write_record(self.path, FitStateRecord(self.cfg, recalls, self.runs, self.predicted))

    def measured(self, severity: float) -> Counts | None:
        """The fitted method's counts at ``severity`` (None when the run did not score it)."""
        return self.runs[_key(severity)].get(self.cfg.method)

    def recall(self, severity: float) -> float | None:
        """The fitted method's max recall at ``severity`` (None when the run had no relevant pair)."""
        m = self.measured(severity)
        return None if m is None else m.recall

    def fitted(self) -> float:
        """The run severity whose recall lies closest to the target (the lower on a tie)."""
        scored = [(float(k), self.recall(float(k))) for k in self.runs]
        scored_ = [(s, r) for s, r in scored if r is not None]
        if not scored_:
            raise ConfigError(f"paper fit: no run of {self.cfg.scenario} had relevant pairs for {self.cfg.method}")
        return min(scored_, key=lambda sr: (abs(sr[1] - self.cfg.target), sr[0]))[0]

    def admitted(self) -> list[float]:
        """The run severities whose recall's 95 % Wilson interval contains the target, and the fitted one."""
        fitted = self.fitted()
        out = []
        for k in self.runs:
            s, m = float(k), self.measured(float(k))
            ci = None if m is None else m.ci
            if s == fitted or (ci is not None and ci[0] <= self.cfg.target <= ci[1]):
                out.append(s)
        return sorted(out)


def default_run(scenario: str, overrides: list[str], run_dir: Path) -> dict[str, tuple[int, int]]:
    """Run ``scenario`` with ``overrides`` in ``run_dir`` (resuming its finished stages).

    Returns per method its cross-robot max hits and relevant pairs.
    """
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    sc = load_scenario(scenario, overrides)
    res = Experiment(sc, run_dir).run()
    out = {}
    for m in res.metrics.methods:
        st = res.metrics.stats(m, kind="inter")
        out[m] = (int(st.max_hits), int(st.n_relevant))
    return out


def _checked(got: dict[str, tuple[int, int]], where: str) -> dict[str, Counts]:
    out = {}
    for m, (hits, rel) in got.items():
        if not 0 <= hits <= rel:
            raise ConfigError(f"{where}: {m} has {hits} hits of {rel} relevant pairs")
        out[m] = Counts(int(hits), int(rel))
    return out


def _evaluate(state: FitState, severity: float, out: Path, run: RunFn) -> float | None:
    key = _key(severity)
    if key not in state.runs:
        cfg = state.cfg
        log.info("paper fit: %s at severity %g", cfg.scenario, severity)
        got = run(cfg.scenario, cfg.run_overrides(severity), out / "runs" / f"{cfg.scenario}_{key}")
        state.runs[key] = _checked(got, f"{cfg.scenario} at severity {severity:g}")
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


@dataclass(frozen=True)
class FitRun:
    """One run of the fit: its severity, the fitted method's max recall with its counts and
    Wilson interval (None when the run did not score it), and whether the severity is admitted."""

    severity: float
    hits: int | None
    relevant: int | None
    max_recall: float | None
    ci: tuple[float, float] | None
    admitted: bool


@dataclass(frozen=True)
class FitResult:
    """The fit (``paper_fit.yaml``'s ``fit``): the figure and the paper's value, the fitted recall and
    severity, the preset, every severity searched with its recall, the admitted severities (the
    ``level`` Wilson interval holds the paper's value), every run and the fit's configuration."""

    figure: str
    paper: float
    fitted: float | None
    severity: float
    preset: str
    searched: list[tuple[float, float | None]]
    level: float
    admitted: list[float]
    runs: list[FitRun]
    config: PaperFitConfig


@dataclass(frozen=True)
class FitFile:
    """``paper_fit.yaml``: the fit, and the preset's ``frontend`` section at the fitted severity
    (explicit error parameters, as a front-end preset file holds them)."""

    fit: FitResult
    frontend: dict[str, JSON]


def _fit_run(state: FitState, s: float, admitted: list[float]) -> FitRun:
    m = state.measured(s)
    if m is None:
        return FitRun(s, None, None, None, None, s in admitted)
    got = m.measure()
    return FitRun(s, got.hits, got.relevant, got.max_recall, got.ci, s in admitted)


def fit_paper_preset(out: str | Path, cfg: PaperFitConfig | None = None, run: RunFn | None = None) -> FitResult:
    """Fit the severity (see the module docstring); write ``paper_fit.yaml`` in ``out``; return the fit."""
    from roman_sim.core.atomic import write_text

    cfg = cfg or PaperFitConfig()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    state = FitState(out, cfg)
    _search(state, out, run or default_run)
    severity = state.fitted()
    admitted = state.admitted()
    done = sorted(float(k) for k in state.runs)
    fit = FitResult(
        figure=f"{cfg.method} max recall, cross-robot pairs, {cfg.scenario}",
        paper=cfg.target,
        fitted=state.recall(severity),
        severity=severity,
        preset=cfg.preset,
        searched=[(s, state.recall(s)) for s in done],
        level=ADMIT_LEVEL,
        admitted=admitted,
        runs=[_fit_run(state, s, admitted) for s in done],
        config=cfg,
    )
    write_text(out / FIT_YAML, yaml.safe_dump(to_json(FitFile(fit, preset_at(cfg.preset, severity))), sort_keys=False))
    return fit


def read_fit(path: str | Path) -> FitResult:
    """The fit of a ``paper_fit.yaml`` (ConfigError for one made before the fit's uncertainty;
    RecordError naming the file and the field for another damage)."""
    from roman_sim.core.config import read_yaml

    data = read_yaml(path)
    fit = data.get("fit") if isinstance(data, dict) else None
    if isinstance(fit, dict) and "runs" not in fit:
        raise ConfigError(f"{path}: made before the fit's uncertainty (no runs); rerun the fit in {Path(path).parent}")
    return from_json(FitFile, data, str(path)).fit


def preset_at(preset: str, severity: float) -> dict[str, JSON]:
    """The preset's ``frontend`` section with its error parameters at ``severity`` (explicit values)."""
    from roman_sim.core.config import validate_model
    from roman_sim.frontend.components import FrontEndConfig

    fe = validate_model(FrontEndConfig, {"preset": preset, "severity": severity}, source="frontend")
    seg = fe.built_segmenter()
    out: dict[str, JSON] = {
        "segmenter": {"name": seg.name, "params": to_json(dict(seg.params))},
        "semantics": fe.built_semantics().model_dump(mode="json"),
    }
    if fe.encoder.name != "simulated" or fe.encoder.params:
        out["encoder"] = fe.encoder.model_dump(mode="json")
    return out


Verdict = Literal["every", "some", "none", "undetermined"]
#: A claim's value at one setting: a number, or the max recall per method (the ordering).
ClaimValue = float | dict[str, float | None] | None
#: Its interval(s): a recall's, per method, or the ratio's two recalls' (``same``, ``opposite``).
ClaimInterval = tuple[float, float] | dict[str, tuple[float, float] | None] | None


@dataclass(frozen=True)
class FittedFigure:
    """The one figure the preset was fitted on: scenario, name, the paper's value and the fitted one."""

    scenario: str
    figure: str
    paper: float
    value: float | None


@dataclass(frozen=True)
class AdmittedSettings:
    """The settings the fit's uncertainty admits: the rule, the intervals' level, the severities."""

    rule: str
    level: float
    severities: list[float]


@dataclass(frozen=True)
class PredictionSetting:
    """One admitted severity: its same-direction figure and its prediction run (None: not run)."""

    severity: float
    fitted: bool
    same: Measure | None
    run: str | None
    max_recall: dict[str, Measure] | None


@dataclass(frozen=True)
class ClaimAt:
    """A claim at one admitted severity: value, interval(s), whether it holds (None: not run)."""

    severity: float
    run: bool
    value: ClaimValue
    ci: ClaimInterval
    holds: bool | None


@dataclass(frozen=True)
class PaperClaim:
    """One held-out prediction over the admitted settings: its value at each, the range and the verdict."""

    claim: str
    paper: float | str
    verdict: Verdict
    holds_for: list[float]
    fails_for: list[float]
    not_run: list[float]
    range: tuple[float, float] | dict[str, tuple[float, float] | None] | None
    settings: list[ClaimAt]


@dataclass(frozen=True)
class PaperPredictions:
    """``paper_predictions.json``: the fitted figure, the admitted settings, each one's runs, the claims."""

    severity: float
    fitted: FittedFigure
    admitted: AdmittedSettings
    scenario: str
    settings: list[PredictionSetting]
    claims: list[PaperClaim]


def read_predictions(path: str | Path) -> PaperPredictions:
    """``paper_predictions.json``; one made before the admitted settings is refused with the fix.

    Raises:
        RecordError: the file is unreadable, predates the admitted settings, or a field is
            missing or of another type (the message names the file and the field).
    """
    data = read_json(path)
    if isinstance(data, dict) and "settings" not in data and "max_recall" in data:
        raise RecordError(
            f"{path}: made before the predictions carried the fit's uncertainty (no admitted settings); "
            f"rewrite it from the runs done: roman-sim paper-preset predict --out {Path(path).parent} --no-run"
        )
    return from_json(PaperPredictions, data, str(path))


def verdict(holds: Sequence[bool], not_run: int) -> Verdict:
    """``some`` when the settings run disagree; else ``undetermined`` if any was not run; else ``every`` / ``none``."""
    if any(holds) and not all(holds):
        return "some"
    if not_run:
        return "undetermined"
    return "every" if holds and all(holds) else "none"


def _span(values: Sequence[float | None]) -> tuple[float, float] | None:
    got = [v for v in values if v is not None]
    return (min(got), max(got)) if got else None


def _claim(text: str, paper: float | str, rows: list[ClaimAt], span: Any) -> PaperClaim:
    ran = [r for r in rows if r.run]
    return PaperClaim(
        claim=text,
        paper=paper,
        verdict=verdict([bool(r.holds) for r in ran], len(rows) - len(ran)),
        holds_for=[r.severity for r in ran if r.holds],
        fails_for=[r.severity for r in ran if not r.holds],
        not_run=[r.severity for r in rows if not r.run],
        range=span,
        settings=rows,
    )


def _claims(settings: list[PredictionSetting], method: str) -> list[PaperClaim]:
    """The three claims over the admitted settings (see the module docstring)."""
    lo, hi = PAPER_OPPOSITE_RECALL - PAPER_OPPOSITE_BAND, PAPER_OPPOSITE_RECALL + PAPER_OPPOSITE_BAND
    ratio_lo, ratio_hi = PAPER_SAME_RECALL / hi, PAPER_SAME_RECALL / lo
    opp, order, ratio = [], [], []
    for st in settings:
        s, figs = st.severity, st.max_recall
        ran = figs is not None
        got = figs or {}
        rec = got.get(method)
        r = None if rec is None else rec.max_recall
        same = None if st.same is None else st.same.max_recall
        opp.append(
            ClaimAt(s, ran, r, None if rec is None else rec.ci, (r is not None and lo <= r <= hi) if ran else None)
        )
        vals = [None if got.get(m) is None else got[m].max_recall for m in ORDERING]
        ordered = all(v is not None for v in vals) and vals[0] > vals[1] > vals[2]  # type: ignore[operator]
        order.append(
            ClaimAt(
                s,
                ran,
                dict(zip(ORDERING, vals)) if ran else None,
                {m: None if got.get(m) is None else got[m].ci for m in ORDERING} if ran else None,
                ordered if ran else None,
            )
        )
        q = same / r if same is not None and r else None
        both = {"same": None if st.same is None else st.same.ci, "opposite": None if rec is None else rec.ci}
        ratio.append(ClaimAt(s, ran, q, both, (q is not None and ratio_lo <= q <= ratio_hi) if ran else None))
    band = f"{PAPER_OPPOSITE_RECALL} +- {PAPER_OPPOSITE_BAND}"
    order_span = {m: _span([o.value.get(m) for o in order if isinstance(o.value, dict)]) for m in ORDERING}
    return [
        _claim(
            f"ROMAN's opposite-direction max recall lies within {band}",
            PAPER_OPPOSITE_RECALL,
            opp,
            _span([o.value for o in opp if not isinstance(o.value, dict)]),
        ),
        _claim(
            "opposite direction: ROMAN > RANSAC-1M > CLIPPER (max recall)",
            "ROMAN > RANSAC-1M > CLIPPER",
            order,
            order_span if any(order_span.values()) else None,
        ),
        _claim(
            f"same/opposite ratio of ROMAN's max recall within {ratio_lo:.2f}-{ratio_hi:.2f}",
            PAPER_RATIO,
            ratio,
            _span([o.value for o in ratio if not isinstance(o.value, dict)]),
        ),
    ]


def predict_paper_preset(
    out: str | Path, cfg: PaperFitConfig | None = None, run: RunFn | None = None, run_missing: bool = True
) -> PaperPredictions:
    """Run ``predict_scenario`` at every admitted severity; write ``paper_predictions.json``; return it.

    Resumable: a prediction run already in ``fit_state.json`` is not run again. With
    ``run_missing=False`` nothing is run: the admitted settings without a prediction run are
    marked not run.
    """
    out = Path(out)
    fit_file = out / FIT_YAML
    if not fit_file.is_file():
        raise ConfigError(f"{fit_file}: file not found (run the fit first: roman-sim paper-preset fit --out {out})")
    cfg = cfg or read_fit(fit_file).config
    state = FitState(out, cfg)
    fitted, admitted = state.fitted(), state.admitted()
    for s in admitted:
        key = _key(s)
        if key in state.predicted or not run_missing:
            continue
        name = f"{cfg.predict_scenario}_{key}"
        log.info("paper predictions: %s at severity %g", cfg.predict_scenario, s)
        got = (run or default_run)(cfg.predict_scenario, cfg.run_overrides(s, predict=True), out / "runs" / name)
        state.predicted[key] = PredictedRun(name, _checked(got, f"{cfg.predict_scenario} at severity {s:g}"))
        state.save()
    settings = []
    for s in admitted:
        same = state.measured(s)
        done = state.predicted.get(_key(s))
        settings.append(
            PredictionSetting(
                severity=s,
                fitted=s == fitted,
                same=None if same is None else same.measure(),
                run=None if done is None else f"runs/{done.run}",
                max_recall=None if done is None else {m: v.measure() for m, v in done.figures.items()},
            )
        )
    rule = (
        f"run severities whose {cfg.method} max recall's {ADMIT_LEVEL * 100:g} % Wilson interval contains "
        f"{cfg.target}, and the fitted one"
    )
    result = PaperPredictions(
        severity=fitted,
        fitted=FittedFigure(
            cfg.scenario,
            f"{cfg.method} max recall, cross-robot pairs, {cfg.scenario}",
            cfg.target,
            state.recall(fitted),
        ),
        admitted=AdmittedSettings(rule, ADMIT_LEVEL, admitted),
        scenario=cfg.predict_scenario,
        settings=settings,
        claims=_claims(settings, cfg.method),
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


def _ci(ci: Any) -> str:
    return "" if ci is None else f" [{ci[0]:.2f}, {ci[1]:.2f}]"


#: What each verdict says, in the results page.
VERDICT_TEXT = {
    "every": "holds for every admitted setting",
    "some": "holds for some admitted settings, not all",
    "none": "holds for no admitted setting",
    "undetermined": "undetermined",
}


def _ordered(v: dict[str, Any]) -> list[tuple[str, Any]]:
    """A per-method mapping in the ordering claim's order (best first), other methods after."""
    return [(m, v[m]) for m in ORDERING if m in v] + [(m, x) for m, x in v.items() if m not in ORDERING]


def _setting_cell(claim: PaperClaim) -> str:
    parts = []
    for r in claim.settings:
        s = f"{r.severity:g}"
        if not r.run:
            parts.append(f"{s}: not run")
            continue
        v, ci = r.value, r.ci
        if isinstance(v, dict):
            cis = ci if isinstance(ci, dict) else {}
            shown = ", ".join(f"{m} {_fmt(x)}{_ci(cis.get(m))}" for m, x in _ordered(v))
        elif isinstance(ci, dict):
            shown = f"{_fmt(v)} (same{_ci(ci.get('same'))}, opposite{_ci(ci.get('opposite'))})"
        else:
            shown = f"{_fmt(v)}{_ci(ci)}"
        parts.append(f"{s}: {shown}, {'holds' if r.holds else 'fails'}")
    return "; ".join(parts)


def range_cell(claim: PaperClaim) -> str:
    """A claim's range over the settings run (per method for the ordering)."""
    span = claim.range
    if isinstance(span, dict):
        return ", ".join(f"{m} {_fmt(v[0])}-{_fmt(v[1])}" for m, v in _ordered(span) if v)
    return "n/a" if span is None else f"{_fmt(span[0])}-{_fmt(span[1])}"


def verdict_cell(claim: PaperClaim) -> str:
    """A claim's verdict in words, with the settings it holds for, fails for and that were not run."""

    def sev(xs: list[float]) -> str:
        return ", ".join(f"{x:g}" for x in xs) or "none"

    return (
        f"{VERDICT_TEXT[claim.verdict]} (holds: {sev(claim.holds_for)}; fails: {sev(claim.fails_for)}"
        + (f"; not run: {sev(claim.not_run)}" if claim.not_run else "")
        + ")"
    )


def preset_block(folder: str | Path) -> str:
    """The results page's paper-preset block (markers included), from a collected fit's JSON and YAML."""
    d = Path(folder)
    fit = read_fit(d / FIT_YAML)
    pred = read_predictions(d / PREDICTIONS)
    begin, end = PRESET_MARKERS
    fitted = next(r for r in fit.runs if r.severity == fit.severity)
    lines = [
        begin,
        f"Fitted on one figure only: {fit.figure} (paper {fit.paper:.2f}), through the severity "
        f"of the `{fit.preset}` preset. Fitted severity {fit.severity:g}: {fitted.hits}/"
        f"{fitted.relevant} = {_fmt(fit.fitted)}{_ci(fitted.ci)}. Admitted (the "
        f"{fit.level * 100:g} % Wilson interval contains {fit.paper}): "
        + ", ".join(f"{s:g}" for s in fit.admitted)
        + ".",
        "",
        "| severity | " + fit.figure + f" [{fit.level * 100:g} % Wilson] | admitted |",
        "|---|---|---|",
        *(
            f"| {r.severity:g}{' (fitted)' if r.severity == fit.severity else ''} | "
            f"{r.hits}/{r.relevant} = {_fmt(r.max_recall)}{_ci(r.ci)} | "
            f"{'yes' if r.admitted else 'no'} |"
            for r in fit.runs
        ),
        "",
        f"Held-out predictions on `{pred.scenario}` at each admitted severity, nothing else changed "
        "(cross-robot max recall [95 % Wilson]; the ratio is the same-direction recall over the "
        "opposite-direction one at the same severity):",
        "",
        "| prediction | paper | per admitted severity | range over the settings run | verdict |",
        "|---|---|---|---|---|",
    ]
    for c in pred.claims:
        lines.append(f"| {c.claim} | {c.paper} | {_setting_cell(c)} | {range_cell(c)} | {verdict_cell(c)} |")
    return "\n".join([*lines, end])
