"""Where the visual method's accepted closures put their 3D-3D inliers, and what that does to the estimate.

For every accepted cross-robot visual closure (``n_assoc >= 5`` with an estimate) of each
finished run folder given, the pair is verified again from the run's own submaps and
keyframes with the run's visual settings (the same candidates, winner and inliers, the
sampler being seeded by the pair) and recorded:

- the estimate's rotation and translation errors (``pairs.csv``) and whether it is correct
  (5 deg / 1 m);
- the inliers: their number, their centroid's depth in the query camera, their RMS distance
  from that centroid (``radius_m``) and the two largest principal standard deviations of
  their 3D points;
- how many of them the true relative pose of the two keyframe cameras (from the truth
  trajectories) also puts within the inlier threshold, and that pose's rotation error.

A compact cluster of inliers (one object) pins the points' centroid but not the rotation
about it: the true pose and one rotated by several degrees both keep most of the cluster
within the 0.3 m threshold, and the sampler's choice between them is chance.

Writes ``benchmarks/out/visual_inliers.json`` (one entry per run folder, keyed by scenario).

Usage: python benchmarks/visual_inliers.py RUN_DIR [RUN_DIR ...]
  e.g. roman-sim run same_direction --out /tmp/sd, then python benchmarks/visual_inliers.py /tmp/sd
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roman_sim.align.visual import attach_keyframes
from roman_sim.align.visual.aligner import VisualAligner, candidates, verify_candidates
from roman_sim.core.atomic import write_json
from roman_sim.core.geometry import inv_T, pose_error
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum
from roman_sim.mapping.io import load_keyframes, load_submaps
from roman_sim.pipeline.scenario import load_scenario

OUT = Path(__file__).resolve().parent / "out" / "visual_inliers.json"


def _pose_at(traj: Trajectory, t: float) -> np.ndarray:
    """The pose of ``traj`` stamped ``t`` (a keyframe's time is one of the truth's frame times)."""
    j = int(np.argmin(np.abs(traj.t - t)))
    if abs(traj.t[j] - t) > 1e-6:
        raise SystemExit(f"no truth pose at keyframe time {t}")
    return np.asarray(traj.T[j], dtype=np.float64)


def measure(run: Path) -> dict[str, Any]:
    """The closures of one run folder (see the module docstring)."""
    sc = load_scenario(str(run / "config.yaml"))
    entry = next(e for e in sc.aligners if e.method == "visual")
    aligner = VisualAligner(**(entry.params or {}))
    robots = [r.name for r in sc.robots]
    subs = {
        r: {
            s.name: s
            for s in attach_keyframes(
                load_submaps(run / "submaps" / f"{r}.npz"), load_keyframes(run / "keyframes" / f"{r}.npz")
            )
        }
        for r in robots
    }
    T_body_cam = {r.name: r.camera.T_body_cam() for r in sc.robots}
    truth = {r: read_tum(run / "trajectories" / f"{r}.truth.tum") for r in robots}
    pairs = pd.read_csv(run / "pairs.csv")
    acc = pairs[(pairs.method == "visual") & (pairs.robot_a != pairs.robot_b) & (pairs.n_assoc >= 5)]
    acc = acc[np.isfinite(acc.rot_err_deg)]
    thr = aligner.params.verify.inlier_threshold_m
    rows = []
    for row in acc.itertuples():
        a, b = subs[row.robot_a][row.a], subs[row.robot_b][row.b]
        ka, kb = a.keyframes, b.keyframes
        out, q, c, _ = verify_candidates(a, b, candidates(ka, kb, aligner.params)[0], aligner.params)
        pq, pc = ka.features(q)[2], kb.features(c)[2]
        if len(out.inliers) != row.n_assoc:
            raise SystemExit(f"{row.a}|{row.b}: re-verified {len(out.inliers)} inliers, the run has {row.n_assoc}")
        Tq = _pose_at(truth[row.robot_a], float(ka.t[q])) @ T_body_cam[row.robot_a]
        Tc = _pose_at(truth[row.robot_b], float(kb.t[c])) @ T_body_cam[row.robot_b]
        T_true = inv_T(Tq) @ Tc
        P = np.asarray(pq, np.float64)[out.inliers[:, 0]]
        Q = np.asarray(pc, np.float64)[out.inliers[:, 1]]
        centred = P - P.mean(axis=0)
        sd = np.linalg.svd(centred, compute_uv=False) / np.sqrt(len(P))
        moved = Q @ T_true[:3, :3].T + T_true[:3, 3]
        rot_q_c, _ = pose_error(out.T_q_c, T_true)
        rows.append(
            {
                "a": row.a,
                "b": row.b,
                "inliers": int(len(P)),
                "rot_err_deg": round(float(row.rot_err_deg), 3),
                "trans_err_m": round(float(row.trans_err_m), 3),
                "correct": bool(row.correct),
                "keyframe_rot_err_deg": round(float(np.degrees(rot_q_c)), 3),
                "depth_m": round(float(P.mean(axis=0)[2]), 3),
                "radius_m": round(float(np.sqrt((centred**2).sum(axis=1).mean())), 3),
                "principal_sd_m": [round(float(v), 3) for v in sd[:2]],
                "true_pose_inliers": int((np.linalg.norm(moved - P, axis=1) <= thr).sum()),
            }
        )
    med = lambda k: float(np.median([r[k] for r in rows])) if rows else None  # noqa: E731
    return {
        "run": str(run),
        "closures": len(rows),
        "correct": sum(r["correct"] for r in rows),
        "median_rot_err_deg": med("rot_err_deg"),
        "median_inliers": med("inliers"),
        "median_radius_m": med("radius_m"),
        "median_depth_m": med("depth_m"),
        "median_true_pose_inlier_share": float(np.median([r["true_pose_inliers"] / r["inliers"] for r in rows]))
        if rows
        else None,
        "rows": rows,
    }


def main() -> None:
    runs = [Path(p) for p in sys.argv[1:]]
    if not runs:
        raise SystemExit(__doc__)
    result = json.loads(OUT.read_text(encoding="utf-8")) if OUT.is_file() else {}
    for run in runs:
        name = load_scenario(str(run / "config.yaml")).name
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        result[name] = {"commit": commit, **measure(run)}
        print(name, {k: v for k, v in result[name].items() if k != "rows"})
    write_json(OUT, result)


if __name__ == "__main__":
    main()
