"""Ground-truth regression helpers for pytest: pin a method's recall on a seeded scenario.

Example (in a user's own test suite)::

    from roman_sim.testing import assert_benchmark, assert_hits, assert_not_worse, run_scenario

    def test_my_aligner_keeps_recall():
        run = run_scenario("smoke", aligners=["my_pkg.align:MyAligner"])   # cached in results/smoke/
        assert_hits(run, "MyAligner", {None: (11, 19), "120-180": (9, 15)})   # (hits, relevant)

    def test_my_aligner_is_not_worse_than_clipper():
        run = run_scenario("demo", aligners=["my_pkg.align:MyAligner"])    # 40 relevant pairs at 120-180
        assert_not_worse(run, "MyAligner", "clipper", heading_bin="120-180")  # paired, margin 0.1

    def test_my_aligner_on_the_quick_benchmark(tmp_path_factory):
        assert_benchmark("my_pkg.align:MyAligner", "quick", pinned={"low/all": (14, 51), "high/all": (6, 48)},
                         out=tmp_path_factory.getbasetemp() / "quick")

Runs are cached in ``out`` (default ``results/<scenario>/seed<seed>-<hash>``): several tests
on the same scenario share one simulation. Figures refer to the run's headline pair set
(cross-robot pairs when the run has them) unless ``kind`` names the other (``inter`` or
``intra``). Pins are counts, hits together with the relevant pairs they are out of, exact by
default: a recall of 2 relevant pairs moves by 0.5 when one pair flips, and a pin of hits
alone would still pass when the relevant pairs grow.
Every helper rejects a pin that cannot fail (empty, NaN, a boolean, a bare number where a
count is meant) with a ``ConfigError`` naming the argument.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np

from roman_sim.benchmark.board_records import Leaderboard, read_leaderboard
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.evaluation.operating_points import POINT_NAMES
from roman_sim.evaluation.paired import MAX_NEEDED
from roman_sim.pipeline.experiment import Experiment, default_run_dir
from roman_sim.pipeline.manifest import is_wall_time_file
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario, method_label

#: The figures ``assert_recall`` bounds (all fractions in [0, 1]).
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
    sc = load_scenario(scenario, sets, list(aligners))
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


def _count(value: Any, what: str) -> int:
    """A non-negative integer (booleans and floats are not counts); ``ConfigError`` naming ``what``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ConfigError(f"{what}: expected a non-negative integer count, got {value!r}")
    if value < 0:
        raise ConfigError(f"{what}: expected a non-negative integer count, got {value!r}")
    return int(value)


def _tolerance(value: Any) -> float:
    """A finite non-negative number of hits (not a boolean)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ConfigError(f"tolerance: expected a finite number >= 0 of hits, got {value!r}")
    if not math.isfinite(float(value)) or value < 0:
        raise ConfigError(f"tolerance: expected a finite number >= 0 of hits, got {value!r}")
    return float(value)


def count_pins(pinned: Any, what: str = "pinned") -> dict[Any, tuple[int, int]]:
    """``{cell: (hits, relevant)}`` validated: non-empty, integer counts, hits within relevant.

    Raises:
        ConfigError: an empty or non-mapping pin, a bare number (hits without relevant
            pairs), NaN, a boolean, a negative count or more hits than relevant pairs.
    """
    if not isinstance(pinned, Mapping):
        raise ConfigError(f"{what}: expected a mapping such as {{None: (11, 20)}}, got {type(pinned).__name__}")
    if not pinned:
        raise ConfigError(f"{what}: an empty pin checks nothing (give {{None: (hits, relevant)}} at least)")
    out: dict[Any, tuple[int, int]] = {}
    for cell, pin in pinned.items():
        where = f"{what}[{cell!r}]"
        if not isinstance(pin, (tuple, list)) or len(pin) != 2:
            raise ConfigError(
                f"{where}: expected (hits, relevant), got {pin!r} (a pin of hits alone still passes when the "
                "relevant pairs change)"
            )
        hits, relevant = _count(pin[0], f"{where} hits"), _count(pin[1], f"{where} relevant")
        if hits > relevant:
            raise ConfigError(f"{where}: {hits} hits out of {relevant} relevant pairs")
        out[cell] = (hits, relevant)
    return out


def check_counts(label: str, got: tuple[int, int], pin: tuple[int, int], tolerance: float) -> str | None:
    """Why ``got`` (hits, relevant) does not match ``pin`` (None when it does)."""
    (h, n), (ph, pn) = got, pin
    if n != pn:
        return f"{label}: relevant pairs changed: pinned {ph}/{pn}, now {h}/{n} (the scenario changed: re-pin)"
    if abs(h - ph) > tolerance:
        return f"{label}: {h}/{n} hits, pinned {ph}/{pn} +- {tolerance:g}"
    return None


def assert_hits(
    run: RunResult,
    method: str,
    pinned: Mapping[str | None, tuple[int, int]],
    tolerance: float = 0,
    kind: str | None = None,
) -> None:
    """Assert ``method``'s max-recall hits and relevant pairs per heading bin (None: overall).

    Args:
        run: a finished run.
        method: aligner label (for ``package.module:Class`` the class name).
        pinned: ``{None: (hits, relevant), "120-180": (hits, relevant)}``; the relevant count must
            match exactly (it follows from the trajectories), the hits within ``tolerance``.
        tolerance: allowed difference in hits (default 0: exact; a finite number >= 0).
        kind: pair set (default: the run's headline set).
    """
    method = method_label(method)
    pins, tol = count_pins(pinned), _tolerance(tolerance)
    for label in pins:
        if label is not None and not isinstance(label, str):
            raise ConfigError(f"pinned: heading bin labels are strings such as '0-60' or None, got {label!r}")
    failures = []
    for label, pin in pins.items():
        s = run.metrics.stats(method, label, kind)
        where = "overall" if label is None else f"heading {label} deg"
        problem = check_counts(f"{method} hits {where}", (s.max_hits, s.n_relevant), pin, tol)
        if problem:
            failures.append(problem)
    assert not failures, "; ".join(failures)


#: Figures ``assert_not_worse`` compares, and the operating point whose threshold each is at.
COUNTED = {
    "max_recall": "max_recall",
    "recall_at_precision_1": "precision_100",
    "recall_at_precision_90": "precision_90",
    "recall_at_acceptance": "acceptance",
}


def _threshold(s: Any, name: str) -> int | None:
    """The threshold k of operating point ``name`` (None: not reached, no pair is a hit)."""
    p = s.operating_points.get(name)
    if p is None:
        raise ConfigError(f"key: this run has no {name!r} operating point (written before they existed?)")
    return None if not p.reached else p.k


def _in_bin(metrics: Any, method: str, kind: str, heading_bin: str | None) -> Any:
    """Whether a heading difference lies in ``heading_bin`` (half-open, the last bin of its table closed)."""
    if heading_bin is None:
        return lambda h: True
    sets = metrics.method(method).set(kind)
    b = sets.bin(heading_bin)
    table = sets.heading_bins if any(x.label == heading_bin for x in sets.heading_bins) else sets.heading_bins_fine
    last = table[-1].label == heading_bin
    return lambda h: b.lo <= h < b.hi or (last and h == b.hi)


def paired_hits(
    run: RunResult, methods: tuple[str, str], key: str, heading_bin: str | None, kind: str | None
) -> tuple[list[bool], list[bool]]:
    """Per relevant pair (same pairs, same order) whether each of two methods hits it at ``key``'s threshold.

    Reads the run's ``pairs.csv`` (or ``pairs.csv.gz``) and checks the hits add up to ``metrics.json``.
    """
    from roman_sim.evaluation.results import read_pairs_csv

    path = run.run_dir / "pairs.csv"
    if not path.is_file() and (run.run_dir / "pairs.csv.gz").is_file():
        path = run.run_dir / "pairs.csv.gz"
    if not path.is_file():
        raise StorageError(f"{path}: missing; a paired comparison needs the run's per-pair results")
    kind = kind or run.metrics.headline
    inside = _in_bin(run.metrics, methods[0], kind, heading_bin)
    by_method: dict[str, dict[tuple[str, str], bool]] = {m: {} for m in methods}
    ks = {m: _threshold(run.metrics.stats(m, heading_bin, kind), COUNTED[key]) for m in methods}
    for s in read_pairs_csv(path):
        t = s.truth
        if s.method in by_method and t.kind == kind and t.relevant and inside(t.heading_diff_deg):
            k = ks[s.method]
            by_method[s.method][(t.a, t.b)] = bool(s.correct and k is not None and s.n_assoc >= k)
    a, b = by_method[methods[0]], by_method[methods[1]]
    if set(a) != set(b):
        raise StorageError(f"{path}: {methods[0]} and {methods[1]} were not scored on the same relevant pairs")
    for m, got in by_method.items():
        st = run.metrics.stats(m, heading_bin, kind)
        want = (st.operating_points[COUNTED[key]].hits, st.n_relevant)  # type: ignore[union-attr]
        if (sum(got.values()), len(got)) != want:
            raise StorageError(f"{path}: {m}'s hits do not add up to metrics.json ({want[0]}/{want[1]})")
    order = sorted(a)
    return [a[p] for p in order], [b[p] for p in order]


def assert_not_worse(
    run: RunResult,
    method: str,
    baseline: str,
    heading_bin: str | None = None,
    key: str = "max_recall",
    margin: float = 0.1,
    level: float = 0.95,
    kind: str | None = None,
) -> None:
    """Assert the run shows ``method``'s recall within ``margin`` of ``baseline``'s, on the same pairs.

    A paired non-inferiority test (``roman_sim.evaluation.paired``): McNemar's exact test on
    the relevant pairs one method hits and the other misses, and an exact upper bound at
    ``level`` of the recall the method loses. It passes only when that bound is at most
    ``margin``: a method whose recall fell fails, and so does a sample too small to show
    anything (the message gives the relevant pairs it would need).

    Args:
        key: a counted figure: ``max_recall``, ``recall_at_precision_1``, ``recall_at_precision_90``,
            ``recall_at_acceptance``; each method at its own threshold for that figure.
        margin: the recall loss still counted as not worse, in (0, 1) (default 0.1: 10 points).
        level: one-sided confidence level of the bound, in [0.5, 1).
    """
    from roman_sim.evaluation.paired import compare_paired

    method, baseline = method_label(method), method_label(baseline)
    if key not in COUNTED:
        raise ConfigError(f"key: {key!r} cannot be compared pair by pair (valid: {', '.join(COUNTED)})")
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not 0.5 <= level < 1.0:
        raise ConfigError(f"level: expected a one-sided confidence level in [0.5, 1), got {level!r}")
    if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not 0.0 < margin < 1.0:
        raise ConfigError(f"margin: expected a recall difference in (0, 1), got {margin!r}")
    if heading_bin is not None and not isinstance(heading_bin, str):
        raise ConfigError(f"heading_bin: expected a bin label such as '120-180' or None, got {heading_bin!r}")
    hits, base = paired_hits(run, (method, baseline), key, heading_bin, kind)
    c = compare_paired(hits, base, float(margin), float(level))
    where = f"{key} {heading_bin or 'overall'}"
    assert c.n, f"{where}: undefined (no relevant pairs): cannot compare {method} with {baseline}"
    if c.not_worse:
        return
    said = (
        f"{method} {where}: {c.hits}/{c.n} against {baseline}'s {c.baseline_hits}/{c.n} on the same pairs "
        f"({c.worse} lost, {c.better} gained, McNemar p = {c.mcnemar_p:.3g}); the recall lost is at most "
        f"{c.loss_upper:.3f} at {level:.0%}, above the margin {margin:g}"
    )
    if c.loss >= margin:
        raise AssertionError(f"{said}: {method} is worse (it lost {c.loss:.3f})")
    need = f"about {c.needed} relevant pairs" if c.needed else f"more than {MAX_NEEDED} relevant pairs"
    raise AssertionError(f"{said}: this sample cannot show it is not worse; it would need {need}")


def benchmark_pins(board: Leaderboard, method: str, point: str = "max_recall") -> dict[str, tuple[int, int]]:
    """``{"<level>/<heading bin>": (hits, relevant)}`` of ``method`` in a leaderboard (``"<level>/all"`` too)."""
    return {cell: (p.hits, p.n_relevant) for cell, p in board.cells_of(method_label(method), point).items()}


def check_benchmark(
    board: Leaderboard,
    method: str,
    pinned: Mapping[str, tuple[int, int]],
    tolerance: float = 0,
    point: str = "max_recall",
) -> None:
    """Assert ``method``'s leaderboard cells (``"<level>/<heading bin>"``) match ``pinned`` (hits, relevant)."""
    pins, tol = count_pins(pinned), _tolerance(tolerance)
    if point not in POINT_NAMES:
        raise ConfigError(f"point: unknown operating point {point!r} (valid: {', '.join(POINT_NAMES)})")
    have = benchmark_pins(board, method, point)
    if not have:
        raise ConfigError(
            f"method {method_label(method)!r} is not in this leaderboard (methods: {', '.join(board.methods)})"
        )
    failures = []
    for cell, pin in pins.items():
        if cell not in have:
            raise ConfigError(f"pinned[{cell!r}]: no such cell (cells: {', '.join(have)})")
        problem = check_counts(f"{method_label(method)} {point} {cell}", have[cell], pin, tol)
        if problem:
            failures.append(problem)
    assert not failures, "; ".join(failures)


def assert_benchmark(
    method: str,
    suite: str | Path = "quick",
    *,
    pinned: Mapping[str, tuple[int, int]],
    tolerance: float = 0,
    point: str = "max_recall",
    out: str | Path | None = None,
    executor: Any = None,
) -> Leaderboard:
    """Run (or reuse) benchmark ``suite`` with ``method`` alone and pin its leaderboard cells.

    Args:
        method: a registered method or ``package.module:Class``.
        suite: ``quick``, ``standard`` or a suite YAML file.
        pinned: ``{"<level>/<heading bin>": (hits, relevant)}``, e.g. ``{"high/150-180": (3, 10),
            "low/all": (40, 51)}`` (``benchmark_pins`` lists a leaderboard's cells).
        tolerance: allowed difference in hits (default 0).
        point: the operating point pinned (``max_recall``, ``precision_90``, ``precision_100``,
            ``acceptance``).
        out: benchmark folder (cached: unchanged cells are not run again); default
            ``results/benchmark/<suite>-<method label>``.
        executor: an ``ExecutorConfig`` (default: this process).

    Returns:
        The leaderboard (``leaderboard.json``), to print or pin more cells from.
    """
    from roman_sim.benchmark.run import BenchmarkJob
    from roman_sim.benchmark.suites import load_suite

    count_pins(pinned)
    _tolerance(tolerance)
    spec = load_suite(suite)
    folder = Path(out) if out is not None else Path("results") / "benchmark" / f"{spec.name}-{method_label(method)}"
    outcome = BenchmarkJob(spec, folder, [method], executor=executor).run()
    assert not outcome.failures, f"benchmark {spec.name}: cells failed: {outcome.failures}"
    board = read_leaderboard(outcome.out_dir / "leaderboard.json")
    check_benchmark(board, method, pinned, tolerance, point)
    return board


def assert_ate_below(run: RunResult, variant: str, reference: str = "odometry", alignment: str = "se3") -> None:
    """Assert ``variant``'s ATE is below ``reference``'s, over the robots every row placed."""
    got = run.ate.rmse(variant, alignment)
    ref = run.ate.rmse(reference, alignment)
    assert got is not None and ref is not None, f"ATE not computable: {variant}={got}, {reference}={ref}"
    assert got < ref, f"ATE of {variant} ({got:.3f} m) is not below {reference} ({ref:.3f} m)"


def run_folder_bytes(run_dir: str | Path) -> dict[str, bytes]:
    """Every file of a run folder by relative path, wall-clock times aside: without ``timings.json`` and
    the aligners' per-pair wall times (``aligned/<label>.times.json``), the only files that differ
    between two runs of one seed."""
    d = Path(run_dir)
    return {
        p.relative_to(d).as_posix(): p.read_bytes()
        for p in sorted(d.rglob("*"))
        if p.is_file() and not is_wall_time_file(p.name)
    }


def assert_same_run_folder(a: str | Path, b: str | Path) -> None:
    """Two run folders hold the same files with the same bytes (timings aside), e.g. across executors."""
    fa, fb = run_folder_bytes(a), run_folder_bytes(b)
    assert sorted(fa) == sorted(fb), f"different files: {sorted(set(fa) ^ set(fb))}"
    differ = [n for n in fa if fa[n] != fb[n]]
    assert not differ, f"files differ: {differ}"
