"""Everything a 3D view shows, read from a finished run folder (nothing is recomputed but
the pose graph's closure verdicts, which a run does not store per closure).

Read: ``config.yaml`` (the scenario), ``trajectories/<robot>.<variant>.tum``, ``maps/*.npz``,
``submaps/*.npz``, ``alignments.json`` and ``pairs.csv``. The loop closures of the
scenario's ``posegraph_method`` are those with a transform and at least
``posegraph.lc_association_thresh`` associations; re-solving the pose graph from the stored
odometry and submaps (milliseconds) tells which of them GNC kept (weight > 0.5), and
``pairs.csv`` tells which are correct.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import StorageError
from roman_sim.core.tum import read_tum
from roman_sim.mapping.io import load_segment_map, load_submaps
from roman_sim.mapping.mapper import SegmentMap
from roman_sim.mapping.types import Submap

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]


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
    """The contents of a run folder (absent parts are empty)."""

    path: Path
    scenario: Any
    trajectories: dict[str, dict[str, tuple[F64, F64]]] = field(default_factory=dict)
    maps: dict[str, SegmentMap] = field(default_factory=dict)
    submaps: dict[str, list[Submap]] = field(default_factory=dict)
    closures: list[Closure] = field(default_factory=list)

    def submap(self, name: str) -> Submap:
        """The submap called ``robot/index``."""
        robot, _, idx = name.partition("/")
        return self.submaps[robot][int(idx)]


def _trajectories(d: Path) -> dict[str, dict[str, tuple[F64, F64]]]:
    out: dict[str, dict[str, tuple[F64, F64]]] = {}
    for f in sorted(d.glob("*.tum")):
        robot, _, variant = f.stem.partition(".")
        if variant:
            out.setdefault(robot, {})[variant] = read_tum(f)
    return out


def _candidate_closures(run: Path, method: str, thresh: int) -> list[dict[str, Any]]:
    path = run / "alignments.json"
    if not path.is_file():
        return []
    try:
        rows = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise StorageError(f"{path}: unreadable ({err})") from None
    return [r for r in rows if r.get("method") == method and r.get("T_a_b") is not None
            and int(r.get("n_associations", 0)) >= thresh]


def _gnc_verdicts(rf: RunFolder, rows: list[dict[str, Any]]) -> list[bool | None]:
    """Whether the re-solved pose graph keeps each closure (None without maps)."""
    from roman_sim.posegraph import LoopClosure, build_and_solve, submap_nodes_from

    if not rf.maps or not rows:
        return [None] * len(rows)
    closures = []
    for r in rows:
        a, b = rf.submap(r["a"]), rf.submap(r["b"])
        closures.append(LoopClosure(a.robot, a.index, b.robot, b.index, np.asarray(r["T_a_b"], dtype=np.float64),
                                    n_associations=int(r["n_associations"])))
    odom = {name: (m.times, m.T_odom_body) for name, m in rf.maps.items()}
    nodes = submap_nodes_from([s for subs in rf.submaps.values() for s in subs])
    res = build_and_solve(odom, {r: nodes.get(r, []) for r in odom}, closures, rf.scenario.posegraph)
    return [None if w is None else w > 0.5 for w in res.closure_weights]


def load_run_folder(run_dir: str | Path) -> RunFolder:
    """Read a finished run folder (``StorageError`` when it is not one)."""
    from roman_sim.evaluation.results import read_pairs_csv
    from roman_sim.pipeline.scenario import load_scenario

    run = Path(run_dir)
    if not (run / "config.yaml").is_file():
        raise StorageError(f"{run}: not a run folder (config.yaml missing)")
    rf = RunFolder(run, load_scenario(run / "config.yaml"))
    rf.trajectories = _trajectories(run / "trajectories")
    rf.maps = {f.stem: load_segment_map(f) for f in sorted((run / "maps").glob("*.npz"))}
    for f in sorted((run / "submaps").glob("*.npz")):
        for s in load_submaps(f):
            rf.submaps.setdefault(s.robot, []).append(s)
    for subs in rf.submaps.values():
        subs.sort(key=lambda s: s.index)
    method = rf.scenario.posegraph_method
    if method is None or not (run / "pairs.csv").is_file():
        return rf
    rows = _candidate_closures(run, method, rf.scenario.posegraph.lc_association_thresh)
    correct = {(s.truth.a, s.truth.b): s.correct for s in read_pairs_csv(run / "pairs.csv") if s.method == method}
    verdicts = _gnc_verdicts(rf, rows)
    rf.closures = [Closure(r["a"], r["b"], int(r["n_associations"]), bool(correct.get((r["a"], r["b"]), False)), v)
                   for r, v in zip(rows, verdicts)]
    return rf
