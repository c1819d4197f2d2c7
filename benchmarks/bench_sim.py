"""Sensor benchmark: frames per second of depth + object ids, and of RGB + depth + ids.

World: the ``forest`` preset (about 1000 objects, 200 x 200 m), seed 0. Camera 640 x 480
(the default ``CameraConfig``), poses along a robot driving the forest loop road (so the views
are representative, not of empty sky). Also times the cheap parts of a run (path planning,
driving + odometry), the depth noise, and whole frames of a robot's frame source (RGB, depth,
ids, noise, odometry; renderer start-up included).
The ``appearance`` section prices each look option (``WorldSpec.appearance``: textures,
instance colour variation, every lighting preset, shadows) as milliseconds per RGB + depth +
ids frame at 320 x 240 and 640 x 480 on the same forest world, next to the default look
measured in the same run (ratios are what to read: the machine is shared), with its memory:
the model's texture bytes and whole buffer, and how much the process grows when a 640 x 480
renderer uploads the world to OpenGL (Mesa keeps textures in process memory). The texture
rows compare one shared texture per surface kind at 256 px (``textures_per_surface_256``,
the look before per-instance textures) with every object part's own texture at 64 px
(``textures``, the default) and 128 px; ``textures_plain_ground`` is the default textures
with the plain 0.2 m ground instead of the detailed one (``ground_texel_m: null``).
Writes ``benchmarks/out/sim.json``. Run: ``python benchmarks/bench_sim.py [--quick]``, or
``--appearance`` to measure only that section and merge it into the existing file.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import roman_sim  # noqa: F401  (headless rendering defaults before mujoco loads)
from roman_sim.core.atomic import write_json
from roman_sim.core.config import validate_model
from roman_sim.core.seeding import child_rng
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.noise import apply_depth_noise
from roman_sim.sim.paths import PathConfig
from roman_sim.sim.render import SensorRenderer
from roman_sim.sim.robot import RobotConfig, plan_paths, trajectory_along
from roman_sim.sim.source import robot_sources
from roman_sim.world import WorldSpec, generate, load_world_spec
from roman_sim.world.appearance import LIGHTING

OUT = Path(__file__).resolve().parent / "out" / "sim.json"


def _fps(renderer: SensorRenderer, poses: list, T_bc) -> float:
    renderer.render(poses[0] @ T_bc)  # warm-up (shader compilation, buffers)
    t0 = time.perf_counter()
    for T in poses:
        renderer.render(T @ T_bc)
    return len(poses) / (time.perf_counter() - t0)


APPEARANCE_OPTIONS: dict[str, dict[str, Any]] = {
    "default": {},
    "textures_per_surface_256": {"textures": True, "texture_scope": "surface", "texture_px": 256},
    "textures": {"textures": True},
    "textures_per_instance_128": {"textures": True, "texture_px": 128},
    "textures_plain_ground": {"textures": True, "ground_texel_m": None},
    "instance_variation_1": {"instance_variation": 1.0},
    "instance_variation_0": {"instance_variation": 0.0},
    **{f"lighting_{name}": {"lighting": name} for name in LIGHTING.names()},
    "shadows": {"shadows": True},
    "shadows_2048": {"shadows": True, "shadow_px": 2048},
    "textures_shadows_evening": {"textures": True, "shadows": True, "lighting": "evening"},
    "default_again": {},  # the default look once more at the end of each round: the reference is their mean
}
SIZES = ((320, 240), (640, 480))


def _rss_mb() -> float:
    """The process's resident memory now (MiB), from /proc (0 where there is none)."""
    try:
        for line in Path("/proc/self/status").read_text(encoding="utf-8").splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def _renderer_mb(world: Any, poses: list) -> float:
    """How much the process grows (MiB) while a 640 x 480 RGB renderer of ``world`` is open."""
    cam = CameraConfig()
    before = _rss_mb()
    with SensorRenderer(world, cam) as r:
        r.render(poses[0] @ cam.T_body_cam())
        return _rss_mb() - before


def _frame_ms(world: Any, cam: CameraConfig, poses: list, rgb: bool = True) -> tuple[float, float]:
    """(median wall ms, median CPU ms of all threads) per frame; CPU time is steadier on a shared machine."""
    r = SensorRenderer(world, cam, rgb=rgb)
    T_bc = cam.T_body_cam()
    try:
        r.render(poses[0] @ T_bc)  # warm-up (shader compilation, texture upload)
        wall, cpu = [], []
        for T in poses:
            t0, c0 = time.perf_counter(), time.process_time()
            r.render(T @ T_bc)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        return 1000.0 * float(np.median(wall)), 1000.0 * float(np.median(cpu))
    finally:
        r.close()


def _timed_row(world: Any, poses: list, depth_only: bool) -> dict[str, float]:
    row: dict[str, float] = {}
    for w, h in SIZES:
        cam = CameraConfig(width=w, height=h)
        row[f"ms_{w}x{h}"], row[f"cpu_ms_{w}x{h}"] = _frame_ms(world, cam, poses)
        if depth_only:
            row[f"depth_ids_only_ms_{w}x{h}"], row[f"depth_ids_only_cpu_ms_{w}x{h}"] = _frame_ms(
                world, cam, poses, rgb=False
            )
    return row


def appearance_costs(poses: list, quick: bool = False) -> dict[str, Any]:
    """Per-frame cost (RGB + depth + ids) of each appearance option at each image size.

    Every option is timed in each of several rounds (options interleaved); a figure is the
    smallest over the rounds of the median over frames, the least disturbed by other jobs.
    """
    base = load_world_spec("forest").model_dump(mode="json")
    poses, rounds = poses[: 6 if quick else 20], 1 if quick else 3
    load_start = os.getloadavg()[0]
    table: dict[str, dict[str, Any]] = {}
    for _ in range(rounds):
        for key, app in APPEARANCE_OPTIONS.items():
            t0, c0 = time.perf_counter(), time.process_time()
            world = generate(validate_model(WorldSpec, {**base, "appearance": app}), 0)
            timed = {"generate_s": time.perf_counter() - t0, "generate_cpu_s": time.process_time() - c0}
            timed.update(_timed_row(world, poses, key == "default"))
            row = table.setdefault(
                key,
                {
                    "textures": int(world.model.ntex),
                    "texture_bytes": int(world.model.ntexdata),
                    "texture_mb": round(world.model.ntexdata / 2**20, 1),
                    "model_mb": round(world.model.nbuffer / 2**20, 1),
                    "meshes": int(world.model.nmesh),
                    "mesh_texcoords": int(world.model.nmeshtexcoord),
                },
            )
            timed["renderer_640x480_mb"] = _renderer_mb(world, poses)
            for k, v in timed.items():
                row[k] = round(min(v, row.get(k, np.inf)), 2 if k.endswith("_s") else 1)
            del world
    for w, h in SIZES:
        ref = (table["default"][f"cpu_ms_{w}x{h}"] + table["default_again"][f"cpu_ms_{w}x{h}"]) / 2
        for row in table.values():
            row[f"cpu_ratio_to_default_{w}x{h}"] = round(row[f"cpu_ms_{w}x{h}"] / ref, 2)
    return {
        "frames_timed": len(poses),
        "rounds": rounds,
        "options": APPEARANCE_OPTIONS,
        "per_option": table,
        "load_average_1m": [round(load_start, 1), round(os.getloadavg()[0], 1)],
        "note": "min over rounds of the median per frame over robot poses on the forest loop; cpu_ms counts "
        "all rendering threads of the process; generate_s is wall time and generate_cpu_s its CPU time; "
        "renderer_640x480_mb is the smallest growth of the process over the rounds; the machine was "
        "shared with other jobs",
    }


def _robot_poses(world: Any, n_frames: int) -> list:
    cfg = RobotConfig(name="bench", path=PathConfig(kind="road", road_index=0), camera=CameraConfig())
    _, T_wb, _ = robot_sources(world, [cfg], 0)[0].run
    return list(T_wb[:: max(1, len(T_wb) // n_frames)][:n_frames])


def appearance_only(quick: bool = False) -> dict:
    """Measure only the appearance section and merge it into the existing ``sim.json``."""
    world = generate(load_world_spec("forest"), 0)
    doc = json.loads(OUT.read_text(encoding="utf-8")) if OUT.is_file() else {}
    doc["appearance"] = appearance_costs(_robot_poses(world, 40), quick)
    write_json(OUT, doc)
    return doc


def main(quick: bool = False) -> dict:
    """Run the benchmark and write its figures."""
    n_frames = 10 if quick else 40
    t0 = time.perf_counter()
    world = generate(load_world_spec("forest"), 0)
    gen_s = time.perf_counter() - t0
    cam = CameraConfig()
    cfg = RobotConfig(name="bench", path=PathConfig(kind="road", road_index=0), camera=cam)
    t0 = time.perf_counter()
    path = plan_paths(world, [cfg], 0)[cfg.name]
    path_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    t, T_wb, _ = trajectory_along(world, cfg, 0, path)
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
    n_sim = sum(1 for _ in robot_sources(world, [sim_cfg], 0)[0].frames())
    sim_fps = n_sim / (time.perf_counter() - t0)
    rng = child_rng(0, "bench", "noise")
    t0 = time.perf_counter()
    for _ in range(10):
        apply_depth_noise(depth, cam.depth_noise, cam.max_depth_m, rng)
    out = {
        "world": {
            "preset": "forest",
            "objects": len(world.truth.objects),
            "ngeom": int(world.model.ngeom),
            "generate_s": round(gen_s, 2),
        },
        "image": [cam.width, cam.height],
        "frames_timed": len(poses),
        **results,
        "targets_fps": {"depth_ids": 10, "rgb_depth_ids": 5},
        "fps_simulate_robot_rgb": round(sim_fps, 2),
        "depth_noise_ms": round((time.perf_counter() - t0) / 10 * 1000, 2),
        "appearance": appearance_costs(poses, quick),
        "path_plan_s": round(path_s, 3),
        "trajectory_s": round(traj_s, 3),
        "trajectory_frames": len(t),
        "machine": {
            "python": platform.python_version(),
            "cpu_count": __import__("os").cpu_count(),
            "note": "2 cores shared with other jobs while measured",
        },
    }
    write_json(OUT, out)
    return out


if __name__ == "__main__":
    run = appearance_only if "--appearance" in sys.argv else main
    sys.stdout.write(json.dumps(run(quick="--quick" in sys.argv), indent=2) + "\n")
