"""Pose-graph benchmark: 3 robots x 1 km, 100 loop closures of which 20 % are false.

Measures the build-and-solve time of the GNC pose graph, how well GNC separates the false
closures, and the ATE before (odometry placed with true initial poses) and after.
Writes ``benchmarks/out/posegraph.json``. Run: ``python benchmarks/bench_posegraph.py``.
"""

from __future__ import annotations

import logging
import platform
import time
from pathlib import Path

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.evaluation.ate import multi_robot_ate
from roman_sim.posegraph import PoseGraphConfig, build_and_solve
from roman_sim.posegraph.synthetic import SyntheticGraphConfig, synthetic_scenario

OUT = Path(__file__).resolve().parent / "out" / "posegraph.json"
SEEDS = (0, 1, 2)


def _run(seed: int, scenario_cfg: SyntheticGraphConfig, cfg: PoseGraphConfig) -> dict:
    start = time.perf_counter()
    sc = synthetic_scenario(seed, scenario_cfg)
    gen_s = time.perf_counter() - start
    res = build_and_solve(sc.odom, sc.submap_nodes, sc.closures, cfg)
    weights = np.array([np.nan if w is None else w for w in res.closure_weights])
    true = np.array(sc.closure_true)
    odom_world = {r: tr.transformed(sc.T_world_odom[r]) for r, tr in sc.odom.items()}
    ate = {}
    for alignment in ("se3", "4dof"):
        before = multi_robot_ate(odom_world, sc.truth, alignment)["all"]
        after = multi_robot_ate(res.trajectories, sc.truth, alignment)["all"]
        ate[alignment] = {"odometry_rmse_m": before.rmse_m, "optimized_rmse_m": after.rmse_m}
    return {
        "seed": seed,
        "scenario_s": gen_s,
        "solve_s": res.runtime_s,
        "n_nodes": int(res.info["n_nodes"]),
        "n_factors": int(res.info["n_factors"]),
        "n_poses": int(sum(len(tr) for tr in sc.odom.values())),
        "n_closures": len(sc.closures),
        "n_false": int((~true).sum()),
        "false_rejected": int(np.sum(weights[~true] < 0.5)),
        "true_kept": int(np.sum(weights[true] > 0.5)),
        "unconnected": res.unconnected,
        "ate": ate,
    }


def main() -> dict:
    """Run the benchmark for a few seeds and write the JSON figures."""
    scenario_cfg = SyntheticGraphConfig(n_robots=3, length_m=1000.0, n_closures=100, outlier_fraction=0.2)
    cfg = PoseGraphConfig()
    runs = [_run(seed, scenario_cfg, cfg) for seed in SEEDS]
    solve = [r["solve_s"] for r in runs]
    figures = {
        "benchmark": "posegraph",
        "scenario": scenario_cfg.model_dump(),
        "posegraph": cfg.model_dump(),
        "machine": {"python": platform.python_version(), "processor": platform.machine()},
        "solve_s_median": float(np.median(solve)),
        "solve_s_max": float(np.max(solve)),
        "runs": runs,
    }
    write_json(OUT, figures)
    return figures


if __name__ == "__main__":
    logging.basicConfig(level=logging.WARNING)
    result = main()
    logging.getLogger(__name__).warning("solve median %.3f s; written %s", result["solve_s_median"], OUT)
