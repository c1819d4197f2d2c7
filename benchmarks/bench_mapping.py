"""Mapping benchmark: front-end throughput at 640 x 480, packet bytes per submap, MB per km.

Two runs: (1) ``dense_synthetic``: ray-cast 640 x 480 frames with about 20 objects within
range (the throughput case); (2) ``world_road``: frames rendered in a generated world while
the robot drives along a road (submaps, packet bytes, MB per km). Only the mapping work
(segmentation, observations + semantics, tracking) is timed; rendering is excluded. Writes ``benchmarks/out/mapping.json``.

Usage: python benchmarks/bench_mapping.py [--world forest] [--seconds 90] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.mapping import synthetic
from roman_sim.mapping.io import packet_bytes
from roman_sim.mapping.mapper import Mapper
from roman_sim.mapping.segmenter import build_segmenter
from roman_sim.mapping.semantics import SimulatedEncoder
from roman_sim.mapping.submap import SubmapConfig, build_submaps
from roman_sim.mapping.tracker import MappingConfig
from roman_sim.mapping.types import Submap
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.paths import PathConfig
from roman_sim.sim.robot import RobotConfig, simulate_robot
from roman_sim.world import generate, load_world_spec

OUT = Path(__file__).parent / "out" / "mapping.json"


class Timed:
    """Wraps a segmenter or encoder and accumulates the seconds spent in it."""

    def __init__(self, inner, method: str) -> None:
        self.inner, self.method, self.seconds, self.calls, self.items = inner, method, 0.0, 0, 0

    def __getattr__(self, name):
        fn = getattr(self.inner, name)
        if name != self.method:
            return fn

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            out = fn(*args, **kwargs)
            self.seconds += time.perf_counter() - t0
            self.calls += 1
            self.items += len(out) if isinstance(out, list) else 1
            return out

        return timed


def _mapper(seed: int, families: dict[int, str]) -> tuple[Mapper, Timed, Timed]:
    seg = Timed(build_segmenter("fastsam", seed), "segment")
    enc = Timed(SimulatedEncoder(seed=seed, families=families), "encode")
    return Mapper(MappingConfig(), seg, enc, seed), seg, enc


def _timing(per_frame: list[float], n_obs: list[int], seg: Timed, enc: Timed) -> dict:
    t = np.asarray(per_frame)
    return {
        "frames": len(t),
        "masks_per_frame": seg.items / max(seg.calls, 1),
        "observations_per_frame": float(np.mean(n_obs)),
        "mapping_fps": float(len(t) / t.sum()),
        "mapping_ms_median": float(np.median(t) * 1e3),
        "mapping_ms_p90": float(np.quantile(t, 0.9) * 1e3),
        "segmenter_ms_per_frame": seg.seconds / max(seg.calls, 1) * 1e3,
        "encoder_ms_per_frame": enc.seconds / max(seg.calls, 1) * 1e3,
    }


def run_dense(n_frames: int, seed: int) -> dict:
    """Throughput on ray-cast 640 x 480 frames with about 20 nearby objects in view."""
    spheres = synthetic.sphere_field(300, seed, x_range=(2.0, 12.0), half_width=6.0, radius_range=(0.15, 0.35))
    frames = synthetic.drive(spheres, n=n_frames, speed=0.5, intr=synthetic.intrinsics(640, 480, 87.0))
    mapper, seg, enc = _mapper(seed, {k: "boulder" for k in range(len(spheres))})
    per_frame, n_obs = [], []
    cpu0 = time.process_time()
    for frame in frames:
        t0 = time.perf_counter()
        n_obs.append(mapper.process(frame))
        per_frame.append(time.perf_counter() - t0)
    out = _timing(per_frame, n_obs, seg, enc)
    out["mapping_fps_cpu_time"] = n_frames / (time.process_time() - cpu0)
    out["segments"] = len(mapper.finish())
    return out


def run_world(world_name: str, seconds: float, seed: int) -> dict:
    """A robot on a road of a generated world: timing, submaps, packet bytes and MB per km."""
    world = generate(load_world_spec(world_name), seed)
    robot = RobotConfig(name="a", path=PathConfig(kind="road"), camera=CameraConfig(width=640, height=480),
                        render_rgb=False, drift="typical", max_duration_s=seconds)
    mapper, seg, enc = _mapper(seed, {o.id: o.family for o in world.truth.objects})
    per_frame, n_obs = [], []
    t_wall = time.perf_counter()
    for frame in simulate_robot(world, robot, seed):
        t0 = time.perf_counter()
        n_obs.append(mapper.process(frame))
        per_frame.append(time.perf_counter() - t0)
    smap = mapper.finish()
    subs = build_submaps(smap, SubmapConfig(descriptor_dtype="float16"))
    packets = [packet_bytes(s) for s in subs]
    length_km = smap.trajectory_length_m / 1000.0
    return {
        "world": world_name, "seed": seed, "image": [640, 480],
        **_timing(per_frame, n_obs, seg, enc),
        "segments": len(smap),
        "submaps": len(subs),
        "segments_per_submap_max": max((len(s) for s in subs), default=0),
        "packet_bytes_mean": float(np.mean(packets)) if packets else 0.0,
        "packet_bytes_max": int(max(packets, default=0)),
        "trajectory_m": smap.trajectory_length_m,
        "mb_per_km": sum(packets) / 1e6 / length_km if length_km > 0 else None,
        "wall_s_including_rendering": time.perf_counter() - t_wall,
    }


def full_submap_bound(seed: int, dim: int = 768) -> dict:
    """Packet bytes of a full submap (40 segments, random unit descriptors) and the MB/km it implies."""
    rng = np.random.default_rng(seed)
    n = SubmapConfig().submap_max_size
    desc = rng.standard_normal((n, dim))
    sub = Submap(robot="a", index=0, t=0.0, T_odom_submap=np.eye(4), segment_ids=np.arange(n),
                 centers=rng.uniform(-15, 15, (n, 3)), volumes=rng.uniform(0.01, 30, n),
                 shape=rng.uniform(0, 1, (n, 3)), descriptors=(desc / np.linalg.norm(desc, axis=1, keepdims=True)),
                 extents=np.sort(rng.uniform(0.2, 5, (n, 3)), axis=1)[:, ::-1])
    nbytes = packet_bytes(sub)
    per_km = 1000.0 / SubmapConfig().submap_center_dist
    return {"segments": n, "descriptor_dim": dim, "packet_bytes": nbytes,
            "mb_per_km_at_one_submap_per_10m": nbytes * per_km / 1e6}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="forest")
    ap.add_argument("--seconds", type=float, default=90.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dense-frames", type=int, default=60)
    args = ap.parse_args()
    result = {
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                    "note": "2 cores shared with other jobs; rendering excluded from timing"},
        "targets": {"mapping_fps": 10, "packet_bytes_max": 125_000, "mb_per_km": 12},
        "dense_synthetic": run_dense(args.dense_frames, args.seed),
        "world_road": run_world(args.world, args.seconds, args.seed),
        "full_submap_bound": full_submap_bound(args.seed),
    }
    write_json(OUT, result)
    for section in ("dense_synthetic", "world_road", "full_submap_bound"):
        for k, v in result[section].items():
            print(f"{section}.{k:28s} {v}")


if __name__ == "__main__":
    main()
