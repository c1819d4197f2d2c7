"""Everything a 3D view shows, read from a finished run folder with the stages' own loaders.

Read: ``config.yaml`` and ``manifest.json`` (which stages completed, their files), the maps,
submaps, evaluation (scores and each method's alignments) and ``trajectories/*.tum``.
Nothing is recomputed but the pose graph's per-closure verdicts, which a run does not
store: the closures of the scenario's ``posegraph_method`` are those with a transform and
at least ``posegraph.lc_association_thresh`` associations; re-solving the graph from the
stored odometry and submaps (milliseconds) tells which of them GNC kept (weight > 0.5),
and the evaluation's scores tell which are correct.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from roman_sim.core.errors import StorageError
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum
from roman_sim.mapping.mapper import SegmentMap
from roman_sim.mapping.types import Submap

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import Scenario
    from roman_sim.pipeline.stages.evaluation import EvaluationOutput
    from roman_sim.pipeline.stages.submaps import Submaps

log = logging.getLogger(__name__)


@dataclass
class Closure:
    """One loop closure of the pose-graph method, with its verdicts.

    Attributes:
        a, b: submap names (``robot/index``).
        n_associations: association count.
        correct: the transform is within the evaluation's tolerances of the truth.
        accepted: the pose graph kept it (GNC inlier); None when the graph was not re-solved.
    """

    a: str
    b: str
    n_associations: int
    correct: bool
    accepted: bool | None


@dataclass
class RunFolder:
    """The contents of a run folder (parts the run did not produce are empty)."""

    path: Path
    scenario: Scenario
    trajectories: dict[str, dict[str, Trajectory]] = field(default_factory=dict)
    maps: dict[str, SegmentMap] = field(default_factory=dict)
    submaps: dict[str, list[Submap]] = field(default_factory=dict)
    closures: list[Closure] = field(default_factory=list)

    def submap(self, name: str) -> Submap:
        """The submap called ``robot/index``."""
        robot, _, idx = name.partition("/")
        return next(s for s in self.submaps[robot] if s.index == int(idx))


def _trajectories(d: Path) -> dict[str, dict[str, Trajectory]]:
    out: dict[str, dict[str, Trajectory]] = {}
    for f in sorted(d.glob("*.tum")):
        robot, _, variant = f.stem.partition(".")
        if variant:
            out.setdefault(robot, {})[variant] = read_tum(f)
    return out


def _closures(rf: RunFolder, evaluation: EvaluationOutput, submaps: Submaps) -> list[Closure]:
    from roman_sim.evaluation.variants import method_closures
    from roman_sim.posegraph import build_and_solve, submap_nodes_from

    sc = rf.scenario
    method, thresh = sc.posegraph_method, sc.posegraph.lc_association_thresh
    if method is None:  # the caller reads closures only of a run with a pose-graph method
        return []
    records = [r for r in evaluation.alignments if r.method == method and r.T_a_b is not None]
    closures = method_closures(submaps.by_name(), evaluation.alignments, method)  # same order as ``records``
    correct = {(s.truth.a, s.truth.b): s.correct for s in evaluation.scores if s.method == method}
    verdicts: list[bool | None] = [None] * len(closures)
    if rf.maps:
        odom = {name: m.odometry for name, m in rf.maps.items()}
        nodes = submap_nodes_from(submaps.all())
        res = build_and_solve(odom, {r: nodes.get(r, []) for r in odom}, closures, sc.posegraph)
        verdicts = [None if w is None else w > 0.5 for w in res.closure_weights]
    return [
        Closure(r.a, r.b, r.n_associations, bool(correct.get((r.a, r.b), False)), v)
        for r, c, v in zip(records, closures, verdicts)
        if c.n_associations >= thresh
    ]


def load_run_folder(run_dir: str | Path) -> RunFolder:
    """Read a finished run folder (``StorageError`` when it is not one or did not complete)."""
    from roman_sim.pipeline.context import RunContext
    from roman_sim.pipeline.manifest import read_manifest
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.pipeline.stages import STAGES

    run = Path(run_dir)
    if not (run / "config.yaml").is_file():
        raise StorageError(f"{run}: not a run folder (config.yaml missing)")
    man = read_manifest(run)
    if not man.complete:
        raise StorageError(f"{run}: the run did not complete (stages missing: {', '.join(man.missing)})")
    rf = RunFolder(run, load_scenario(run / "config.yaml"))
    ctx = RunContext(rf.scenario, run)
    out = {
        s.name: s.load(ctx, man.stages[s.name].files)
        for s in STAGES
        if s.name in ("maps", "submaps", "evaluation") and s.name in man.stages
    }
    rf.trajectories = _trajectories(run / "trajectories")
    rf.maps = out["maps"].maps if "maps" in out else {}
    rf.submaps = out["submaps"].submaps if "submaps" in out else {}
    if rf.scenario.posegraph_method is not None and "evaluation" in out and "submaps" in out:
        rf.closures = _closures(rf, out["evaluation"], out["submaps"])
    return rf
