"""Fixtures shared by every test area; hand-made submaps, pair truths, scores and alignment results
(``make_submap``, ``make_truth``, ``make_score``, ``result_for``) for the evaluation and report tests.

The helper modules beside this file (``committed_results``: the committed result folders the
tests may read; ``figure_checks``: checks of a figure as it is saved; ``processes``: the
processes a run leaves behind) are importable from every test.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest
from typer.testing import CliRunner, Result

from roman_sim.align.base import AlignResult
from roman_sim.core.geometry import pose_4dof
from roman_sim.evaluation.metrics import PairScore
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.mapping.types import Submap, SubmapTruth

# Tests never share stages through the user's cache (nor fill it): each run computes what its
# own folder lacks. The tests of the shared cache give it a folder of their own.
os.environ["ROMAN_SIM_CACHE"] = "off"

if TYPE_CHECKING:
    from roman_sim.pipeline.result import RunResult

sys.path.append(str(Path(__file__).parent))


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """The bundled smoke scenario, seed 0 (run once per test session)."""
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import load_scenario

    return Experiment(load_scenario("smoke"), tmp_path_factory.mktemp("smoke") / "seed0").run()


@pytest.fixture
def run_cli(capsys: pytest.CaptureFixture[str]) -> Callable[..., tuple[int, str, str]]:
    """Run ``roman-sim ARGS`` through the real entry point; returns (exit code, stdout, stderr)."""
    from roman_sim.cli import app

    def run(*args: str) -> tuple[int, str, str]:
        try:
            app(list(args), prog_name="roman-sim")
            code = 0
        except SystemExit as ex:
            code = int(ex.code or 0)
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


@pytest.fixture
def cli_fails() -> Callable[..., str]:
    """``cli_fails(*args)``: run ``roman-sim ARGS``, assert one clean error line and exit code 1, return the line.

    ``allow_progress=True`` also accepts progress-bar lines drawn before the error line.

    Fails the test when an exception other than ``SystemExit`` escapes the command (a
    traceback in a real shell) or stderr holds anything but the one ``error: ...`` line.
    """
    from roman_sim.cli import app

    def run(*args: object, allow_progress: bool = False) -> str:
        result = CliRunner().invoke(app, [str(a) for a in args])
        escaped = result.exception is not None and not isinstance(result.exception, SystemExit)
        assert not escaped, f"uncaught {type(result.exception).__name__}: {result.exception}"
        assert result.exit_code == 1, (result.exit_code, result.output)
        assert "Traceback" not in result.output
        lines = result.stderr.strip().splitlines()
        if allow_progress:  # a progress bar drawn before the failure (its lines hold no "error:")
            assert not any("error" in line.lower() for line in lines[:-1]), result.stderr
            lines = lines[-1:]
        assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
        return lines[0]

    return run


#: A user's package of aligner plug-ins, ``myteam.align``: ``EveryOtherPair`` is ROMAN on every other
#: pair (its closures and hits a part of ROMAN's, so its row and its pose graph differ from ROMAN's);
#: ``Raises`` passes the dry call (two synthetic submaps of robots "a" and "b") and raises on a run's pairs.
USER_ALIGNERS = """\
from roman_sim.align import build_aligner
from roman_sim.align.base import AlignResult


class EveryOtherPair:
    name = "EveryOtherPair"

    def __init__(self):
        self.roman = build_aligner("roman", {})

    def align(self, a, b):
        if (a.index + b.index) % 2:
            return AlignResult.failure(self.name, "every other pair")
        out = self.roman.align(a, b)
        out.method = self.name
        return out


class Raises:
    name = "raises"

    def align(self, a, b):
        if a.robot in ("a", "b"):
            return AlignResult.failure(self.name, "declines")
        raise RuntimeError("model weights missing")
"""


@pytest.fixture(scope="module")
def user_package(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A folder holding the user's package ``myteam`` (``myteam/align.py``: ``USER_ALIGNERS``), imported
    afresh from it by the test module that uses it (and forgotten after: modules and import path)."""
    home = tmp_path_factory.mktemp("user")
    (home / "myteam").mkdir()
    (home / "myteam" / "__init__.py").write_text("")
    (home / "myteam" / "align.py").write_text(USER_ALIGNERS)
    for name in ("myteam.align", "myteam"):
        sys.modules.pop(name, None)
    yield home
    for name in ("myteam.align", "myteam"):
        sys.modules.pop(name, None)
    # a plug-in import from the current folder appends that folder to sys.path: forget it too
    sys.path[:] = [p for p in sys.path if not p or os.path.realpath(p) != os.path.realpath(home)]


@pytest.fixture(scope="session")
def invoke_in() -> Callable[..., Result]:
    """``invoke_in(folder, *args)``: ``roman-sim ARGS`` run from ``folder`` (where a user's package is found)."""
    from roman_sim.cli import app

    def run(folder: Path, *args: str) -> Result:
        mp = pytest.MonkeyPatch()
        mp.chdir(folder)
        try:
            return CliRunner().invoke(app, list(args))
        finally:
            mp.undo()

    return run


def _make_submap(
    robot: str, index: int, x: float, y: float, yaw_deg: float = 0.0, object_ids=(0, 1, 2), with_points: bool = False
) -> Submap:
    """A submap whose segments are objects placed on a small grid around its centre."""
    ids = np.asarray(object_ids, dtype=np.int64)
    n = len(ids)
    centers = np.stack([np.arange(n) * 1.5 - n, (np.arange(n) % 3) * 2.0 - 2.0, np.full(n, 0.5)], 1)
    points = None
    if with_points:
        offs = np.array([[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0], [0, 0, 0.4]], dtype=float)
        points = [c + offs for c in centers]
    return Submap(
        robot=robot,
        index=index,
        t=float(index),
        T_odom_submap=pose_4dof(x, y, 0.0, np.radians(yaw_deg)),
        segment_ids=np.arange(n, dtype=np.int64) + 100 * index,
        centers=centers.astype(float),
        volumes=np.ones(n),
        shape=np.full((n, 3), 1 / 3),
        descriptors=np.eye(n, 8, dtype=np.float32),
        extents=np.tile([1.0, 0.5, 0.3], (n, 1)),
        points=points,
        truth=SubmapTruth(pose_4dof(x, y, 0.0, np.radians(yaw_deg)), ids, np.ones(n)),
    )


def _make_truth(
    name: str,
    relevant: bool,
    heading: float = 0.0,
    ambiguity: float = float("nan"),
    kind: str = "inter",
    true_corr: int = 0,
) -> PairTruth:
    """A pair truth with only the fields the metrics read set meaningfully."""
    return PairTruth(
        a=f"a/{name}",
        b=f"b/{name}",
        robot_a="a",
        robot_b="b" if kind == "inter" else "a",
        index_a=0,
        index_b=int(name) if name.isdigit() else 1,
        T_a_b_true=np.eye(4),
        center_dist_m=5.0 if relevant else 50.0,
        heading_diff_deg=heading,
        overlap=0.5,
        ambiguity=ambiguity,
        relevant=relevant,
        kind=kind,  # type: ignore[arg-type]
        shared_objects=true_corr,
        true_correspondences=true_corr,
    )


def _make_score(
    name: str,
    relevant: bool,
    n_assoc: int,
    correct: bool,
    method: str = "m",
    heading: float = 0.0,
    ambiguity: float = float("nan"),
    runtime: float = 0.1,
    kind: str = "inter",
    true_corr: int = 0,
    assoc_correct: int = 0,
) -> PairScore:
    """A scored pair with given counts and outcome (and association truth counts)."""
    err = 0.1 if correct else 40.0
    return PairScore(
        _make_truth(name, relevant, heading, ambiguity, kind, true_corr),
        method,
        n_assoc,
        err,
        err,
        correct,
        runtime,
        None if n_assoc else "no associations",
        assoc_correct,
        assoc_correct,
    )


def _result_for(T, n_assoc: int, method: str = "m", n_segments: int = 3) -> AlignResult:
    """An AlignResult with ``n_assoc`` associations (i % n_segments, i % n_segments)."""
    idx = np.arange(n_assoc) % n_segments
    assoc = np.stack([idx, idx], 1).astype(np.int64)
    return AlignResult(
        method=method,
        T_a_b=None if T is None else np.asarray(T, float),
        associations=assoc,
        scores=np.ones(n_assoc),
        runtime_s=0.01,
        reason=None if T is not None else "failed",
    )


@pytest.fixture(name="make_submap")
def _make_submap_fixture():
    return _make_submap


@pytest.fixture(name="make_truth")
def _make_truth_fixture():
    return _make_truth


@pytest.fixture(name="make_score")
def _make_score_fixture():
    return _make_score


@pytest.fixture(name="result_for")
def _result_for_fixture():
    return _result_for


#: The test files that take longest (a minute or more of CPU each), longest first. With
#: ``--dist loadfile`` each file runs on one worker, in collection order: starting these first
#: keeps one long file from running alone at the end of the suite.
LONGEST_FIRST = (
    "tests/benchmark/test_quick.py",
    "tests/pipeline/test_visual.py",
    "tests/test_docs_examples.py",
    "tests/pipeline/test_regression.py",
    "tests/runner/test_executors.py",
    "tests/pipeline/test_scenario_stats.py",
    "tests/cli/test_interrupts.py",
    "tests/pipeline/test_run_features.py",
    "tests/scoring/test_external_score.py",
    "tests/benchmark/test_run.py",
    "tests/benchmark/test_plugin_row.py",
    "tests/runner/test_dask_security.py",
    "tests/test_wheel.py",
    "tests/pipeline/test_sweep.py",
    "tests/pipeline/test_bundled_scenarios.py",
)


def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list[pytest.Item]) -> None:
    """Collect the longest files first (a stable sort: every other file keeps its order)."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda it: rank.get(it.nodeid.split("::", 1)[0], len(rank)))
