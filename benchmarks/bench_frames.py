"""Per-frame cost of the maps stage, step by step, on a short part of three scenario kinds.

For the first robot of ``demo`` (320 x 240, RGB for the visual method), ``kimera_outdoor``
(paper scale: 8000 objects, 160 x 120, no RGB) and ``demo_pixels`` (the image front end,
RGB on every frame), the first ``--frames`` frames are rendered and mapped as the maps
stage does (same segmenter, encoder, front-end grader and keyframe extractor; RGB on the
frames the pipeline renders it for) and the CPU time (``time.process_time``, all threads
of this process, so the renderer's too) of every step is summed:

- render: ``rgb_pass`` (the colour pass: draw + read back, on the frames that get RGB),
  ``depth_ids_pass`` (the segmentation pass: draw + read back of depth and id colours),
  ``depth`` (reversed-Z to metres, then the depth noise), ``ids`` (id colours to object ids,
  the rest of ``SensorRenderer.render``);
- front end: ``segment``, ``observe`` (back-projection, range and plane filters, voxel
  downsampling: the mapper's time less the other steps), ``encode``, ``track`` (voxel IoU
  association, merges, lifecycle), ``grade`` (the front-end grader's hook) and ``keyframes``
  (the visual method's extractor).

Each part is run ``--repeats`` times and every step keeps its smallest total (on a shared
machine the fastest repeat is the one other jobs inflated least). Per scenario it reports
milliseconds per frame of every step, the render time of the frames the run needs and of
RGB on every frame, and ``mapping_over_render``: the front end's time over the render time
of the frames it needs (target at most 1.3). Writes ``benchmarks/out/frames.json``
(``--label`` names the entry; ``baseline`` keeps the figures of an older checkout).

``--dense DIR`` instead maps ``bench_mapping``'s dense synthetic frames (640 x 480 ray-cast,
about 20 objects in range, fastsam + simulated encoder) with this checkout and with the one
whose ``roman_sim/`` is in ``DIR`` (e.g. ``git archive <commit> roman_sim | tar -x -C DIR``),
each in its own subprocess, alternating ``--repeats`` times, and records the CPU time per
frame of the whole mapper and of its segmenter (the front-end engineer's part) for each.

Usage: python benchmarks/bench_frames.py [--frames 400] [--repeats 2] [--label current]
       [--scenarios demo kimera_outdoor demo_pixels] [--dense DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from roman_sim.core.atomic import write_json

OUT = Path(__file__).resolve().parent / "out" / "frames.json"
RENDER_STEPS = ("rgb_pass", "depth_ids_pass", "depth", "ids")
FRONTEND_STEPS = ("segment", "observe", "encode", "track", "grade", "keyframes")
#: Frames of each scenario's first robot (a short part of a paper-scale run).
DEFAULT_FRAMES = {"demo": 400, "kimera_outdoor": 300, "demo_pixels": 150}


class Clock:
    """CPU seconds per step; ``wrap`` times a callable into a step."""

    def __init__(self) -> None:
        self.s: dict[str, float] = defaultdict(float)

    def wrap(self, step: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                self.s[step] += time.process_time() - t0

        return timed


class Timed:
    """A segmenter or encoder whose ``methods`` add their CPU time to ``step`` of ``clock``."""

    def __init__(self, inner: Any, clock: Clock, step: str, methods: tuple[str, ...]) -> None:
        self._inner, self._clock, self._step, self._methods = inner, clock, step, methods

    def __getattr__(self, name: str) -> Any:
        fn = getattr(self._inner, name)
        return self._clock.wrap(self._step, fn) if name in self._methods else fn


def _patch_renderer(clock: Clock) -> Callable[[], None]:
    """Time the two OpenGL passes, depth decoding and the whole ``render``; returns the undo."""
    from roman_sim.sim import render as render_mod
    from roman_sim.sim import robot as robot_mod

    saved = (mujoco.mjr_render, mujoco.mjr_readPixels, render_mod.SensorRenderer.render)
    saved_lin, saved_noise = render_mod.SensorRenderer._linear_depth, robot_mod.apply_depth_noise
    draw, read, render = saved[0], saved[1], saved[2]
    seg_flag = mujoco.mjtRndFlag.mjRND_SEGMENT

    def mjr_render(rect: Any, scene: Any, con: Any) -> None:
        step = "depth_ids_pass" if scene.flags[seg_flag] else "rgb_pass"
        clock.wrap(step, draw)(rect, scene, con)

    def mjr_read(rgb: Any, depth: Any, rect: Any, con: Any) -> None:
        clock.wrap("rgb_pass" if depth is None else "depth_ids_pass", read)(rgb, depth, rect, con)

    mujoco.mjr_render, mujoco.mjr_readPixels = mjr_render, mjr_read
    render_mod.SensorRenderer.render = clock.wrap("render_total", render)
    render_mod.SensorRenderer._linear_depth = clock.wrap("depth_linear", saved_lin)
    robot_mod.apply_depth_noise = clock.wrap("depth_noise", saved_noise)

    def undo() -> None:
        mujoco.mjr_render, mujoco.mjr_readPixels, render_mod.SensorRenderer.render = saved
        render_mod.SensorRenderer._linear_depth, robot_mod.apply_depth_noise = saved_lin, saved_noise

    return undo


def _rgb_schedule(ctx: Any, run: Any) -> Any:
    """The frames the pipeline renders RGB for (None: all; an older checkout renders all)."""
    try:
        from roman_sim.pipeline.stages.maps_input import rgb_frames
    except ImportError:
        return None
    return rgb_frames(ctx, run.t, run.T_odom_body)


def _one_pass(ctx: Any, world: Any, cfg: Any, run: Any, families: dict[int, str]) -> tuple[dict[str, float], dict]:
    """Render and map ``run`` once as the maps stage does; CPU seconds per step and counts."""
    from roman_sim.align.visual import KeyframeExtractor, default_vocabulary
    from roman_sim.mapping.mapper import Mapper
    from roman_sim.pipeline.stages import maps_robot
    from roman_sim.sim.robot import render_trajectory

    sc, clock = ctx.scenario, Clock()
    seg = Timed(maps_robot.build_segmenter_for(ctx, cfg.name), clock, "segment", ("segment",))
    enc = Timed(maps_robot.build_encoder_for(ctx, cfg.name, families), clock, "encode", ("encode", "encode_batch"))
    grader = maps_robot._Grader(sc.frontend.semantics.group_of, sc.seed, cfg.name)
    grader.use(families)
    mapper = Mapper(sc.mapping, seg, enc, seed=sc.seed, on_frame=clock.wrap("grade", grader.add))
    mapper.tracker.update = clock.wrap("track", mapper.tracker.update)  # type: ignore[method-assign]
    process = clock.wrap("mapper", mapper.process)
    extractor = KeyframeExtractor(default_vocabulary(), sc.frontend.keyframes) if sc.uses_visual else None
    offer = None if extractor is None else clock.wrap("keyframes", extractor.offer)
    undo = _patch_renderer(clock)
    rgb_frames, schedule = 0, _rgb_schedule(ctx, run)
    try:
        frames = render_trajectory(world, cfg, sc.seed, run, *([] if schedule is None else [schedule]))
        for frame in frames:
            rgb_frames += frame.rgb is not None
            process(frame)
            if offer is not None:
                offer(frame.public())
    finally:
        undo()
    s = dict(clock.s)
    s["ids"] = s.pop("render_total", 0.0) - sum(s.get(k, 0.0) for k in ("rgb_pass", "depth_ids_pass", "depth_linear"))
    s["depth"] = s.pop("depth_linear", 0.0) + s.pop("depth_noise", 0.0)
    s["observe"] = s.pop("mapper", 0.0) - sum(s.get(k, 0.0) for k in ("segment", "encode", "track", "grade"))
    counts = {"rgb_frames": rgb_frames, "keyframes": 0 if extractor is None else len(extractor.keyframes)}
    counts["segments"] = len(mapper.finish())
    return s, counts


def measure(name: str, n_frames: int, repeats: int) -> dict:
    """The per-step breakdown of the first ``n_frames`` frames of ``name``'s first robot."""
    import tempfile

    from roman_sim.pipeline.context import RunContext
    from roman_sim.pipeline.scenario import load_scenario
    from roman_sim.sim.robot import DrivenRun, plan_paths, trajectory_along
    from roman_sim.world import generate

    sc = load_scenario(name)
    world = generate(sc.world.spec(), sc.seed)
    cfg = sc.robots[0]
    t, T_wb, T_ob = trajectory_along(world, cfg, sc.seed, plan_paths(world, sc.simulated_robots(), sc.seed)[cfg.name])
    n = min(n_frames, len(t))
    run = DrivenRun(t[:n], T_wb[:n], T_ob[:n])
    families = {o.id: o.family for o in world.truth.objects}
    best: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as d:
        ctx = RunContext(sc, Path(d))
        for _ in range(repeats):
            s, counts = _one_pass(ctx, world, cfg, run, families)
            best = {k: min(v, best.get(k, np.inf)) for k, v in s.items()}
    return _summary(name, cfg, n, len(t), best, counts, repeats)


def _summary(name: str, cfg: Any, n: int, n_run: int, best: dict[str, float], counts: dict, repeats: int) -> dict:
    ms = {k: 1e3 * best.get(k, 0.0) / n for k in (*RENDER_STEPS, *FRONTEND_STEPS)}
    rgb = counts["rgb_frames"]
    per_rgb_frame = 1e3 * best.get("rgb_pass", 0.0) / rgb if rgb else 0.0
    render = sum(ms[k] for k in RENDER_STEPS)
    frontend = sum(ms[k] for k in FRONTEND_STEPS)
    return {
        "scenario": name,
        "robot": cfg.name,
        "image": [cfg.camera.width, cfg.camera.height],
        "frames": n,
        "frames_in_run": n_run,
        "repeats": repeats,
        **counts,
        "ms_per_frame": ms,
        "rgb_pass_ms_per_rgb_frame": per_rgb_frame,
        "render_ms_per_frame": render,
        "render_ms_per_frame_rgb_on_every_frame": render - ms["rgb_pass"] + (per_rgb_frame if cfg.render_rgb else 0.0),
        "frontend_ms_per_frame": frontend,
        "mapping_over_render": frontend / render,
    }


DENSE = """
import json, sys, time
sys.path.insert(0, {bench!r})
import numpy as np
from bench_mapping import _mapper
from roman_sim.mapping import synthetic
spheres = synthetic.sphere_field(300, 0, x_range=(2.0, 12.0), half_width=6.0, radius_range=(0.15, 0.35))
frames = list(synthetic.drive(spheres, n=60, speed=0.5, intr=synthetic.intrinsics(640, 480, 87.0)))
mapper, seg, enc = _mapper(0, {{k: "boulder" for k in range(len(spheres))}})
inner, seg_cpu = seg.inner.segment, [0.0]
def timed(frame):
    t0 = time.process_time()
    out = inner(frame)
    seg_cpu[0] += time.process_time() - t0
    return out
seg.inner.segment = timed
per = []
for f in frames:
    t0 = time.process_time()
    mapper.process(f)
    per.append(time.process_time() - t0)
print(json.dumps({{"ms_median": 1e3 * float(np.median(per)), "ms_mean": 1e3 * float(np.mean(per)),
                  "segmenter_ms_mean": 1e3 * seg_cpu[0] / len(per), "segments": len(mapper.finish())}}))
"""


def dense(baseline: Path, repeats: int) -> dict:
    """CPU per frame of the dense synthetic mapping path: this checkout against ``baseline``."""
    import sys

    code = DENSE.format(bench=str(Path(__file__).resolve().parent))
    roots = {"current": Path(__file__).resolve().parent.parent, "baseline": baseline}
    runs: dict[str, list[dict]] = {k: [] for k in roots}
    for _ in range(repeats):
        for name, root in roots.items():
            env = {**os.environ, "PYTHONPATH": str(root)}
            out = subprocess.run([sys.executable, "-c", code], env=env, cwd=root, capture_output=True, text=True)
            runs[name].append(json.loads(out.stdout.strip().splitlines()[-1]))
    best = {k: min(v, key=lambda r: r["ms_mean"]) for k, v in runs.items()}
    return {
        "runs": runs,
        "best": best,
        "frontend_speedup_mean": best["baseline"]["ms_mean"] / best["current"]["ms_mean"],
        "without_segmenter_speedup_mean": (best["baseline"]["ms_mean"] - best["baseline"]["segmenter_ms_mean"])
        / (best["current"]["ms_mean"] - best["current"]["segmenter_ms_mean"]),
    }


def _machine() -> dict:
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    except OSError:
        commit = ""
    return {
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "commit": commit,
        "note": "2 cores shared with other jobs: CPU time of this process, fastest of the repeats",
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="+", default=list(DEFAULT_FRAMES))
    ap.add_argument("--frames", type=int, default=None, help="frames per scenario (default: per scenario)")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--label", default="current")
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--dense", type=Path, default=None, help="older checkout to compare the dense path with")
    args = ap.parse_args()
    result = json.loads(args.out.read_text()) if args.out.is_file() else {}
    if args.dense is not None:
        result["dense_synthetic"] = {**dense(args.dense, args.repeats), "machine": _machine()}
        write_json(args.out, result)
        print(json.dumps(result["dense_synthetic"]["best"], indent=1))
        return
    entry = result.get(args.label, {})
    entry["machine"] = _machine()
    for name in args.scenarios:
        entry[name] = measure(name, args.frames or DEFAULT_FRAMES.get(name, 300), args.repeats)
        print(json.dumps(entry[name], indent=1))
    result[args.label] = entry
    result["target_mapping_over_render"] = 1.3
    write_json(args.out, result)


if __name__ == "__main__":
    main()
