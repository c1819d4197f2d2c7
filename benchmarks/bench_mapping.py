"""Mapping benchmark: front-end throughput at 640 x 480, packet bytes per submap, MB per km.

Runs: (1) ``dense_synthetic``: ray-cast 640 x 480 frames with about 20 objects within
range (the throughput case); (2) ``world_road``: frames rendered in a generated world while
the robot drives along a road (submaps, packet bytes, MB per km); (3) ``image_frontend``:
the truth-free image segmenter + encoder against the truth-driven fastsam + simulated front
end on the same rendered RGB-D frames of the textured demo world (``demo_pixels``), at
320 x 240 and 640 x 480 (frames per second of segmenter + encoder in wall and CPU time,
each one's time per frame, and the whole mapper). Only the mapping work is timed; rendering is excluded. Writes
``benchmarks/out/mapping.json``; ``--sections`` runs some runs and keeps the other figures.

Usage: python benchmarks/bench_mapping.py [--world forest] [--seconds 90] [--seed 0]
       [--sections dense_synthetic world_road full_submap_bound image_frontend]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from roman_sim.core.atomic import write_json
from roman_sim.frontend.segmenter import simulated_segmenter
from roman_sim.frontend.semantics import SimulatedEncoder
from roman_sim.mapping import synthetic
from roman_sim.mapping.io import packet_bytes
from roman_sim.mapping.mapper import Mapper
from roman_sim.mapping.submap import SubmapConfig, build_submaps
from roman_sim.mapping.tracker import MappingConfig
from roman_sim.mapping.types import Submap
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.paths import PathConfig
from roman_sim.sim.robot import RobotConfig
from roman_sim.sim.source import robot_sources
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
    seg = Timed(simulated_segmenter("fastsam", seed), "segment")
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
    robot = RobotConfig(
        name="a",
        path=PathConfig(kind="road"),
        camera=CameraConfig(width=640, height=480),
        render_rgb=False,
        drift="typical",
        max_duration_s=seconds,
    )
    mapper, seg, enc = _mapper(seed, {o.id: o.family for o in world.truth.objects})
    per_frame, n_obs = [], []
    t_wall = time.perf_counter()
    for frame in robot_sources(world, [robot], seed)[0].frames():
        t0 = time.perf_counter()
        n_obs.append(mapper.process(frame))
        per_frame.append(time.perf_counter() - t0)
    smap = mapper.finish()
    subs = build_submaps(smap, SubmapConfig(descriptor_dtype="float16"))
    packets = [packet_bytes(s) for s in subs]
    length_km = smap.trajectory_length_m / 1000.0
    return {
        "world": world_name,
        "seed": seed,
        "image": [640, 480],
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
    sub = Submap(
        robot="a",
        index=0,
        t=0.0,
        T_odom_submap=np.eye(4),
        segment_ids=np.arange(n),
        centers=rng.uniform(-15, 15, (n, 3)),
        volumes=rng.uniform(0.01, 30, n),
        shape=rng.uniform(0, 1, (n, 3)),
        descriptors=(desc / np.linalg.norm(desc, axis=1, keepdims=True)),
        extents=np.sort(rng.uniform(0.2, 5, (n, 3)), axis=1)[:, ::-1],
    )
    nbytes = packet_bytes(sub)
    per_km = 1000.0 / SubmapConfig().submap_center_dist
    return {
        "segments": n,
        "descriptor_dim": dim,
        "packet_bytes": nbytes,
        "mb_per_km_at_one_submap_per_10m": nbytes * per_km / 1e6,
    }


def _frontend_timing(frames: list, segmenter, encoder, families) -> dict:
    """Segmenter, encoder (all masks of a frame at once) and whole-mapper time on ``frames``."""
    from roman_sim.mapping.observation import observe_indexed
    from roman_sim.mapping.protocols import reads_truth

    seg_s, enc_s, seg_cpu, enc_cpu, masks = [], [], 0.0, 0.0, 0
    cfg = MappingConfig()
    for f in frames:
        seen = f if reads_truth(segmenter) else f.public()
        c0, t0 = time.process_time(), time.perf_counter()
        ms = segmenter.segment(seen)
        c1, t1 = time.process_time(), time.perf_counter()
        observe_indexed(f, ms, cfg, encoder)  # back-projection + the encoder, as the mapper runs it
        c2, t2 = time.process_time(), time.perf_counter()
        seg_s.append(t1 - t0)
        enc_s.append(t2 - t1)
        seg_cpu += c1 - c0
        enc_cpu += c2 - c1
        masks += len(ms)
    mapper = Mapper(cfg, segmenter, encoder)
    t0 = time.perf_counter()
    for f in frames:
        mapper.process(f)
    mapper_s = time.perf_counter() - t0
    seg_t, enc_t = float(np.sum(seg_s)), float(np.sum(enc_s))
    return {
        "frames": len(frames),
        "masks_per_frame": masks / len(frames),
        "frontend_fps": len(frames) / (seg_t + enc_t),
        "frontend_fps_cpu_time": len(frames) / (seg_cpu + enc_cpu),
        "segmenter_ms_per_frame": seg_t / len(frames) * 1e3,
        "segmenter_cpu_ms_per_frame": seg_cpu / len(frames) * 1e3,
        "encoder_ms_per_frame": enc_t / len(frames) * 1e3,
        "encoder_cpu_ms_per_frame": enc_cpu / len(frames) * 1e3,
        "mapper_fps": len(frames) / mapper_s,
        "segments": len(mapper.finish()),
    }


def run_image_frontend(n_frames: int, seed: int) -> dict:
    """Image front end vs truth-driven front end on the same frames of the textured demo world.

    The encoder's time includes the back-projection of each mask (what ``observe`` does
    around the encoder), so both front ends are timed the same way.
    """
    from roman_sim.frontend.components import build_encoder
    from roman_sim.frontend.components import build_segmenter as build_any_segmenter
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.sim.robot import DrivenRun, plan_paths, render_trajectory, trajectory_along

    sc = load_scenario("demo_pixels")
    world = generate(sc.world.spec(), sc.seed)
    families = {o.id: o.family for o in world.truth.objects}
    out: dict = {"scenario": "demo_pixels", "world_seed": sc.seed}
    for w, h in ((320, 240), (640, 480)):
        robot = sc.robots[0].model_copy(update={"render_rgb": True, "camera": CameraConfig(width=w, height=h)})
        path = plan_paths(world, [robot], sc.seed)[robot.name]
        t, T_wb, T_ob = trajectory_along(world, robot, sc.seed, path)
        keep = np.linspace(0, len(t) - 1, min(n_frames, len(t))).round().astype(int)
        frames = list(render_trajectory(world, robot, sc.seed, DrivenRun(t[keep], T_wb[keep], T_ob[keep])))
        image = _frontend_timing(frames, build_any_segmenter("image", seed), build_encoder("image"), families)
        truth = _frontend_timing(
            frames, build_any_segmenter("fastsam", seed), build_encoder("simulated", seed, "a", families), families
        )
        out[f"{w}x{h}"] = {
            "image": image,
            "truth_driven": truth,
            "image_over_truth_frontend_time": truth["frontend_fps"] / image["frontend_fps"],
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="forest")
    ap.add_argument("--seconds", type=float, default=90.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dense-frames", type=int, default=60)
    ap.add_argument("--image-frames", type=int, default=60)
    runs = {
        "dense_synthetic": lambda a: run_dense(a.dense_frames, a.seed),
        "world_road": lambda a: run_world(a.world, a.seconds, a.seed),
        "full_submap_bound": lambda a: full_submap_bound(a.seed),
        "image_frontend": lambda a: run_image_frontend(a.image_frames, a.seed),
    }
    ap.add_argument("--sections", nargs="+", choices=sorted(runs), default=list(runs))
    args = ap.parse_args()
    result = json.loads(OUT.read_text()) if OUT.is_file() else {}
    result.update(
        {
            "machine": {
                "cpus": os.cpu_count(),
                "python": platform.python_version(),
                "note": "2 cores shared with other jobs; rendering excluded from timing",
            },
            "targets": {
                "mapping_fps": 10,
                "packet_bytes_max": 125_000,
                "mb_per_km": 12,
                "image_frontend_fps_320x240": 10,
            },
        }
    )
    for section in args.sections:
        result[section] = runs[section](args)
    write_json(OUT, result)
    for section in args.sections:
        for k, v in result[section].items():
            print(f"{section}.{k:28s} {v}")


if __name__ == "__main__":
    main()
