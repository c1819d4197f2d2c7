"""Pose graphs of a run and their trajectory errors, TUM files and trajectory plot.

Three trajectories per robot are scored against the truth:

- ``odometry``: the drifting odometry, each robot placed with its true initial pose;
- ``<method>``: the multi-robot pose graph with the chosen aligner's loop closures;
- ``oracle``: the same pose graph with the true relative pose of every relevant pair (the
  upper bound of what loop closures can give).
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import EvaluationError
from roman_sim.evaluation.ate import multi_robot_ate
from roman_sim.evaluation.trajplot import plot_trajectories
from roman_sim.geometry import gravity_aligned, pose_error
from roman_sim.posegraph import LoopClosure, build_and_solve, submap_nodes_from
from roman_sim.core.tum import write_tum

if TYPE_CHECKING:
    from roman_sim.pipeline.experiment import Experiment

log = logging.getLogger(__name__)

ORACLE_ASSOCIATIONS = 1_000_000


def _by_name(exp: "Experiment") -> dict[str, Any]:
    return {s.name: s for subs in exp._state["submaps"].values() for s in subs}


def method_closures(exp: "Experiment", method: str) -> list[LoopClosure]:
    """Loop closures proposed by ``method`` (every pair with a transform; the graph applies k)."""
    subs = _by_name(exp)
    out = []
    for row in exp._state["alignments"]:
        if row["method"] != method or row["T_a_b"] is None:
            continue
        a, b = subs[row["a"]], subs[row["b"]]
        out.append(LoopClosure(a.robot, a.index, b.robot, b.index, np.asarray(row["T_a_b"], dtype=np.float64),
                               n_associations=int(row["n_associations"]), source=method))
    return out


def oracle_closures(exp: "Experiment") -> list[LoopClosure]:
    """True relative poses of every relevant pair."""
    subs = _by_name(exp)
    out = []
    for (a_name, b_name), t in sorted(exp._state["truths"].items()):
        if t.relevant:
            a, b = subs[a_name], subs[b_name]
            out.append(LoopClosure(a.robot, a.index, b.robot, b.index, np.asarray(t.T_a_b_true),
                                   n_associations=ORACLE_ASSOCIATIONS, source="oracle"))
    return out


def _score(est: dict[str, Any], ref: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for alignment in ("se3", "4dof"):
        try:
            res = multi_robot_ate(est, ref, alignment)
        except EvaluationError as err:
            log.warning("ATE (%s) not computable: %s", alignment, err)
            res = {}
        out[alignment] = {k: (None if v is None else v.rmse_m) for k, v in res.items()}
        if "all" not in out[alignment]:
            out[alignment]["all"] = None
    return out


def solve_and_score(exp: "Experiment") -> dict[str, Any]:
    """Solve the pose graphs, write TUM files and the plot; return the ATE table."""
    maps = exp._state["maps"]
    truth = {r: (m.times, m.T_world_body) for r, m in maps.items()}
    odom = {r: (m.times, m.T_odom_body) for r, m in maps.items()}
    placed = {r: (t, gravity_aligned(truth[r][1][0]) @ T) for r, (t, T) in odom.items()}
    nodes = submap_nodes_from([s for subs in exp._state["submaps"].values() for s in subs])
    nodes = {r: nodes.get(r, []) for r in maps}
    method = exp.sc.posegraph_method or ""
    ate: dict[str, Any] = {"odometry": _score(placed, truth)}
    info: dict[str, Any] = {}
    notes: list[str] = []
    estimates: dict[str, Any] = {}
    for variant, closures in ((method, method_closures(exp, method)), ("oracle", oracle_closures(exp))):
        res = build_and_solve(odom, nodes, closures, exp.sc.posegraph)
        estimates[variant] = (res, closures)
        ate[variant] = _score(res.trajectories, truth)
        used = [w for w in res.closure_weights if w is not None]
        info[variant] = {"closures": len(closures), "closures_used": len(used), "inliers": res.n_inliers,
                         "unconnected": res.unconnected, "runtime_s": res.runtime_s}
        if res.unconnected:
            notes.append(f"{variant} pose graph: robot(s) {', '.join(res.unconnected)} never connected "
                         "to the first robot; their ATE is not computable")
        if not used:
            notes.append(f"{variant} pose graph: no loop closure accepted")
    write_json(exp.dir / "posegraph.json", info)
    exp._state["pg_notes"] = notes
    _write_trajectories(exp, truth, placed, estimates)
    return ate


def _write_trajectories(exp: "Experiment", truth: dict[str, Any], placed: dict[str, Any],
                        estimates: dict[str, Any]) -> None:
    d = exp.dir / "trajectories"
    for r, (t, T) in truth.items():
        write_tum(d / f"{r}.truth.tum", t, T)
        write_tum(d / f"{r}.odometry.tum", *placed[r])
    for variant, (res, _) in estimates.items():
        for r, (t, T) in res.trajectories.items():
            write_tum(d / f"{r}.{variant}.tum", t, T)
    method = exp.sc.posegraph_method or ""
    res, closures = estimates[method]
    est_world = _aligned_estimate(res.trajectories, truth)
    lines = _closure_lines(exp, closures, res.closure_weights)
    try:
        plot_trajectories(exp.dir / "plots" / "trajectories.png", truth, est=est_world or None, odom=placed,
                          closures=lines, title=f"{exp.sc.name}: truth, odometry and {method} pose graph")
    except EvaluationError as err:
        exp._state.setdefault("pg_notes", []).append(f"trajectory plot not drawn: {err}")


def _aligned_estimate(est: dict[str, Any], truth: dict[str, Any]) -> dict[str, Any]:
    """The estimate moved onto the truth by the concatenated SE(3) alignment."""
    if not est:
        return {}
    try:
        T_align = multi_robot_ate(est, {r: truth[r] for r in est}, "se3")["all"]
    except EvaluationError:
        return {}
    if T_align is None:
        return {}
    A = T_align.T_align
    return {r: (t, A @ T) for r, (t, T) in est.items()}


def _closure_lines(exp: "Experiment", closures: list[LoopClosure], weights: list[Any]) -> list[Any]:
    subs = _by_name(exp)
    thresh = exp.sc.posegraph.lc_association_thresh
    lines = []
    for c, w in zip(closures, weights):
        if w is None or c.n_associations < thresh:
            continue
        a, b = subs[f"{c.robot_a}/{c.submap_a}"], subs[f"{c.robot_b}/{c.submap_b}"]
        Ta, Tb = a.truth.T_world_submap, b.truth.T_world_submap
        rot, trans = pose_error(c.T_a_b, np.linalg.inv(Ta) @ Tb)
        ok = math.degrees(rot) <= exp.sc.evaluation.rot_tol_deg and trans <= exp.sc.evaluation.trans_tol_m
        lines.append((Ta[:3, 3], Tb[:3, 3], "inter" if c.inter else "intra", bool(ok)))
    return lines
