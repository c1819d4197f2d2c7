"""Ground-truth regression helpers for pytest: pin a method's recall on a seeded scenario.

Example (in a user's own test suite)::

    from roman_sim.testing import assert_recall, run_scenario

    def test_my_aligner_keeps_recall(tmp_path_factory):
        run = run_scenario("smoke", aligners=["my_pkg.align:MyAligner"],
                           out=tmp_path_factory.getbasetemp() / "smoke")
        assert_recall(run, "MyAligner", {"0-60": 0.2, "120-180": 0.1})
        assert_not_worse(run, "MyAligner", "clipper", heading_bin="120-180")

Runs are cached in ``out``: several tests on the same scenario share one simulation. Figures
refer to the run's headline pair set (cross-robot pairs when the run has them) unless
``kind`` names the other (``inter`` or ``intra``). Prefer pinning counts
(``assert_hits``): a recall of 2 relevant pairs moves by 0.5 when one pair flips.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import cast

from roman_sim.core.errors import ConfigError
from roman_sim.pipeline.experiment import Experiment, default_run_dir
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario, method_label, with_aligners

#: The figures ``assert_recall`` and ``assert_not_worse`` compare (all fractions in [0, 1]).
FIGURES = ("max_recall", "recall_at_precision_1", "best_f1", "auc")


def names_list(value: object, what: str) -> list[str]:
    """``value`` as a list of strings; ``ConfigError`` for a bare string (a list is meant) or non-strings."""
    if isinstance(value, (str, bytes)):
        raise ConfigError(f"{what}: expected a list of strings, got the string {value!r} (write {what}=[{value!r}])")
    try:
        items = list(cast(Iterable[object], value))  # a non-iterable raises TypeError here
    except TypeError:
        raise ConfigError(f"{what}: expected a list of strings, got {type(value).__name__}") from None
    bad = [x for x in items if not isinstance(x, str)]
    if bad:
        raise ConfigError(f"{what}: every entry must be a string, got {bad[0]!r}")
    return [str(x) for x in items]


def _check_key(key: object) -> str:
    if key not in FIGURES:
        raise ConfigError(f"key: unknown figure {key!r} (valid: {', '.join(FIGURES)})")
    return str(key)


def _fraction(value: object, what: str) -> float:
    """A finite number in [0, 1] (booleans are not numbers here); ``ConfigError`` naming ``what``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{what}: expected a number in [0, 1], got {value!r}")
    if not math.isfinite(value) or not 0.0 <= value <= 1.0:
        raise ConfigError(f"{what}: expected a finite number in [0, 1], got {value!r}")
    return float(value)


def run_scenario(
    scenario: str | Path,
    *,
    aligners: Iterable[str] = (),
    overrides: Iterable[str] = (),
    seed: int | None = None,
    out: str | Path | None = None,
) -> RunResult:
    """Run (or reuse) a seeded scenario with extra aligners (names or ``package.module:Class``)."""
    aligners, overrides = names_list(aligners, "aligners"), names_list(overrides, "overrides")
    sets = list(overrides) + ([f"seed={seed}"] if seed is not None else [])
    sc = with_aligners(load_scenario(scenario, sets), list(aligners))
    run_dir = Path(out) / f"seed{sc.seed}" if out is not None else default_run_dir(sc)
    return Experiment(sc, run_dir).run()


def assert_recall(
    run: RunResult,
    method: str,
    minimum: float | Mapping[str, float],
    key: str = "max_recall",
    kind: str | None = None,
) -> None:
    """Assert ``method``'s recall is at least ``minimum`` overall, or per heading bin.

    Args:
        run: a finished run.
        method: aligner label (for ``package.module:Class`` the class name).
        minimum: one overall bound, or ``{"0-60": 0.5, "120-180": 0.2}`` per heading bin.
        key: which figure (``max_recall``, ``recall_at_precision_1``, ``best_f1``, ``auc``).
        kind: pair set (default: the run's headline set).
    """
    method, key = method_label(method), _check_key(key)
    bounds = _bounds(minimum)
    failures = []
    for bin_label, lo in bounds.items():
        got = _figure(run, method, bin_label, key, kind)
        where = "overall" if bin_label is None else f"heading {bin_label} deg"
        if got is None:
            failures.append(f"{method} {key} {where}: undefined (no relevant pairs), bound {lo}")
        elif got < lo:
            failures.append(f"{method} {key} {where}: {got:.3f} < {lo}")
    assert not failures, "; ".join(failures)


def _bounds(minimum: object) -> dict[str | None, float]:
    """``{None: bound}`` or ``{bin label: bound}``, every bound a finite fraction."""
    if isinstance(minimum, Mapping):
        if not minimum:
            raise ConfigError("minimum: an empty mapping checks nothing (give {'0-60': 0.5, ...} or a number)")
        out: dict[str | None, float] = {}
        for label, lo in minimum.items():
            if not isinstance(label, str):
                raise ConfigError(f"minimum: heading bin labels are strings such as '0-60', got {label!r}")
            out[label] = _fraction(lo, f"minimum[{label!r}]")
        return out
    return {None: _fraction(minimum, "minimum")}


def _figure(run: RunResult, method: str, bin_label: str | None, key: str, kind: str | None = None) -> float | None:
    return run.metrics.figure(method, bin_label, key, kind)


def assert_hits(
    run: RunResult, method: str, pinned: Mapping[str | None, int], tolerance: int = 1, kind: str | None = None
) -> None:
    """Assert ``method``'s max-recall hits per heading bin (None: overall) are within ``tolerance``."""
    method = method_label(method)
    failures = []
    for bin_label, hits in pinned.items():
        s = run.metrics.stats(method, bin_label, kind)
        if abs(s.max_hits - hits) > tolerance:
            where = "overall" if bin_label is None else f"heading {bin_label} deg"
            failures.append(f"{method} hits {where}: {s.max_hits}/{s.n_relevant}, pinned {hits} +- {tolerance}")
    assert not failures, "; ".join(failures)


def assert_not_worse(
    run: RunResult,
    method: str,
    baseline: str,
    heading_bin: str | None = None,
    key: str = "max_recall",
    tolerance: float = 0.0,
    kind: str | None = None,
) -> None:
    """Assert ``method`` reaches at least ``baseline``'s figure (minus ``tolerance``)."""
    method, baseline, key = method_label(method), method_label(baseline), _check_key(key)
    tolerance = _fraction(tolerance, "tolerance")
    if heading_bin is not None and not isinstance(heading_bin, str):
        raise ConfigError(f"heading_bin: expected a bin label such as '120-180' or None, got {heading_bin!r}")
    got, ref = _figure(run, method, heading_bin, key, kind), _figure(run, baseline, heading_bin, key, kind)
    assert got is not None and ref is not None, f"{key} undefined: {method}={got}, {baseline}={ref}"
    assert got >= ref - tolerance, f"{method} {key} {heading_bin or 'overall'}: {got:.3f} < {baseline} {ref:.3f}"


def assert_ate_below(run: RunResult, variant: str, reference: str = "odometry", alignment: str = "se3") -> None:
    """Assert ``variant``'s ATE is below ``reference``'s, over the robots every row placed."""
    got = run.ate.rmse(variant, alignment)
    ref = run.ate.rmse(reference, alignment)
    assert got is not None and ref is not None, f"ATE not computable: {variant}={got}, {reference}={ref}"
    assert got < ref, f"ATE of {variant} ({got:.3f} m) is not below {reference} ({ref:.3f} m)"


def run_folder_bytes(run_dir: str | Path) -> dict[str, bytes]:
    """Every file of a run folder except the wall-clock ``timings.json``, by relative path."""
    d = Path(run_dir)
    return {
        p.relative_to(d).as_posix(): p.read_bytes()
        for p in sorted(d.rglob("*"))
        if p.is_file() and p.name != "timings.json"
    }


def assert_same_run_folder(a: str | Path, b: str | Path) -> None:
    """Two run folders hold the same files with the same bytes (timings aside), e.g. across executors."""
    fa, fb = run_folder_bytes(a), run_folder_bytes(b)
    assert sorted(fa) == sorted(fb), f"different files: {sorted(set(fa) ^ set(fb))}"
    differ = [n for n in fa if fa[n] != fb[n]]
    assert not differ, f"files differ: {differ}"
