"""Sensor benchmark: frames per second of depth + object ids, and of RGB + depth + ids.

World: the ``forest`` preset (about 1000 objects, 200 x 200 m), seed 0. Camera 640 x 480
(the default ``CameraConfig``), poses along a robot driving the forest loop road (so the views
are representative, not of empty sky). Also times the cheap parts of a run (path planning,
driving + odometry), the depth noise, and whole ``simulate_robot`` frames (RGB, depth,
ids, noise, odometry; renderer start-up included).
Writes ``benchmarks/out/sim.json``. Run: ``python benchmarks/bench_sim.py [--quick]``.
"""

from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

import roman_sim  # noqa: F401  (headless rendering defaults before mujoco loads)
from roman_sim.core.atomic import write_json
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.noise import apply_depth_noise
from roman_sim.sim.paths import PathConfig
from roman_sim.sim.render import SensorRenderer
from roman_sim.sim.robot import RobotConfig, robot_path, robot_trajectory, simulate_robot
from roman_sim.core.seeding import child_rng
from roman_sim.world import generate, load_world_spec

OUT = Path(__file__).resolve().parent / "out" / "sim.json"


def _fps(renderer: SensorRenderer, poses: list, T_bc) -> float:
    renderer.render(poses[0] @ T_bc)  # warm-up (shader compilation, buffers)
    t0 = time.perf_counter()
    for T in poses:
        renderer.render(T @ T_bc)
    return len(poses) / (time.perf_counter() - t0)


def main(quick: bool = False) -> dict:
    """Run the benchmark and write its figures."""
    n_frames = 10 if quick else 40
    t0 = time.perf_counter()
    world = generate(load_world_spec("forest"), 0)
    gen_s = time.perf_counter() - t0
    cam = CameraConfig()
    cfg = RobotConfig(name="bench", path=PathConfig(kind="road", road_index=0), camera=cam)
    t0 = time.perf_counter()
    robot_path(world, cfg, 0)
    path_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    t, T_wb, _ = robot_trajectory(world, cfg, 0)
    traj_s = time.perf_counter() - t0
    step = max(1, len(T_wb) // n_frames)
    poses = list(T_wb[::step][:n_frames])
    T_bc = cam.T_body_cam()
    results = {}
    for key, rgb in (("depth_ids", False), ("rgb_depth_ids", True)):
        r = SensorRenderer(world, cam, rgb=rgb)
        try:
            results[f"fps_{key}"] = round(_fps(r, poses, T_bc), 2)
        finally:
            r.close()
    r = SensorRenderer(world, cam, rgb=False)
    _, depth, _ = r.render(poses[0] @ T_bc)
    r.close()
    sim_cfg = cfg.model_copy(update={"max_duration_s": (n_frames - 1) / cfg.rate_hz})
    t0 = time.perf_counter()
    n_sim = sum(1 for _ in simulate_robot(world, sim_cfg, 0))
    sim_fps = n_sim / (time.perf_counter() - t0)
    rng = child_rng(0, "bench", "noise")
    t0 = time.perf_counter()
    for _ in range(10):
        apply_depth_noise(depth, cam.depth_noise, cam.max_depth_m, rng)
    out = {
        "world": {"preset": "forest", "objects": len(world.truth.objects), "ngeom": int(world.model.ngeom),
                  "generate_s": round(gen_s, 2)},
        "image": [cam.width, cam.height],
        "frames_timed": len(poses),
        **results,
        "targets_fps": {"depth_ids": 10, "rgb_depth_ids": 5},
        "fps_simulate_robot_rgb": round(sim_fps, 2),
        "depth_noise_ms": round((time.perf_counter() - t0) / 10 * 1000, 2),
        "path_plan_s": round(path_s, 3),
        "trajectory_s": round(traj_s, 3),
        "trajectory_frames": len(t),
        "machine": {"python": platform.python_version(), "cpu_count": __import__("os").cpu_count(),
                    "note": "2 cores shared with other jobs while measured"},
    }
    write_json(OUT, out)
    return out


if __name__ == "__main__":
    import json

    sys.stdout.write(json.dumps(main(quick="--quick" in sys.argv), indent=2) + "\n")
