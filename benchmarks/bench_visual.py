"""Visual-method benchmark: keyframe features + BoW at 640 x 480, vocabulary training, per-pair time.

Frames: one robot drives 30 m of a loop in the textured ``offroad`` preset (seed 9300, no
scenario uses it) with the D455 camera (640 x 480, RGB + noisy depth); a second robot
retraces it in the same direction. Every frame goes through ``KeyframeExtractor`` (ORB, 700 features,
BoW with the shipped vocabulary; keyframe every 1 m); extraction is timed on its own
(rendering excluded) over every frame, in frames per second of wall time and of process
CPU time (the latter is less disturbed by other jobs on a shared machine). Submaps: every 10 keyframes;
per-pair time of the ``visual`` aligner over every pair of the two robots' submaps.
Vocabulary: training time of ``train_vocabulary`` (k = 10, L = 4) on the descriptors of
the benchmark frames (rendering of the shipped training set excluded; ``--full`` re-runs
the shipped training end to end), and the shipped file's size.
Demo (``--demo``): the bundled demo run fresh with and without the visual method (without:
no visual aligner, no RGB, no textures, as the demo was before it), wall time of each and
their ratio, in one process one after the other.
Writes ``benchmarks/out/visual.json``. Run: ``python benchmarks/bench_visual.py [--quick] [--full] [--demo]``.
"""

from __future__ import annotations

import importlib.util
import json
import os
import platform
import sys
import time
from importlib import resources
from pathlib import Path

import numpy as np

from roman_sim.align import build_aligner
from roman_sim.align.visual import (
    KeyframeExtractor,
    KeyframeParams,
    attach_keyframes,
    default_vocabulary,
)
from roman_sim.align.visual.vocabulary import train_vocabulary
from roman_sim.core.atomic import write_json
from roman_sim.mapping.submap import SubmapConfig, make_submap
from roman_sim.sim.paths import PathConfig
from roman_sim.sim.robot import (
    RobotConfig,
    plan_paths,
    render_trajectory,
    trajectory_along,
)
from roman_sim.world import generate, load_world_spec

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "out" / "visual.json"
SEED = 9300


def _robots(quick: bool) -> list[RobotConfig]:
    length = 12.0 if quick else 30.0
    path = PathConfig(kind="loop", radius_m=6.0)
    return [
        RobotConfig(name="a", path=path, max_length_m=length),
        RobotConfig(name="b", path=PathConfig(kind="retrace", of="a", pieces=[(0.0, 1.0)]), max_length_m=length),
    ]


def _demo_times() -> dict:
    """Wall time of the demo with and without the visual method (fresh runs, one process)."""
    import tempfile

    from roman_sim.core.config import validate_model
    from roman_sim.pipeline.experiment import Experiment
    from roman_sim.pipeline.scenario import Scenario, load_scenario

    with_visual = load_scenario("demo")
    data = with_visual.model_dump(mode="json")
    data["aligners"] = [a for a in data["aligners"] if a["method"] != "visual"]
    data["world"]["overrides"].pop("appearance.textures", None)
    for r in data["robots"]:
        r["render_rgb"] = False
    before = validate_model(Scenario, data, source="demo without visual")
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, sc in (("demo_before_s", before), ("demo_with_visual_s", with_visual)):
            t0 = time.perf_counter()
            Experiment(sc, Path(tmp) / label, fresh=True).run()
            out[label] = time.perf_counter() - t0
    out["ratio"] = out["demo_with_visual_s"] / out["demo_before_s"]
    return out


def _textured_world():
    from roman_sim.world.appearance import AppearanceSpec

    spec = load_world_spec("offroad")
    return generate(spec.model_copy(update={"appearance": AppearanceSpec(textures=True)}), SEED)


def _drive(world, cfg, path, voc):
    """(frames, extraction seconds, keyframes, submaps) of one robot."""
    ex = KeyframeExtractor(voc, KeyframeParams(every_m=1.0))
    timer = KeyframeExtractor(voc, KeyframeParams(every_m=1e-9, every_deg=1e-9, every_s=1e-9))  # every frame
    traj = trajectory_along(world, cfg, SEED, path)
    spent, cpu, n = 0.0, 0.0, 0
    for frame in render_trajectory(world, cfg, SEED, traj):
        t0, c0 = time.perf_counter(), time.process_time()
        timer.offer(frame)
        spent += time.perf_counter() - t0
        cpu += time.process_time() - c0
        n += 1
        ex.offer(frame)
    kfs = ex.keyframes
    subs = []
    for k, s in enumerate(range(0, len(kfs), 10)):
        i = int(np.argmin(np.abs(traj[0] - kfs[s].t)))
        subs.append(make_submap(cfg.name, k, float(traj[0][i]), traj[2][i], traj[1][i], [], SubmapConfig()))
    return n, (spent, cpu), timer.keyframes, attach_keyframes(subs, kfs)


def main(quick: bool = False, full: bool = False, demo: bool = False) -> dict:
    voc = default_vocabulary()
    world = _textured_world()
    robots = _robots(quick)
    paths = plan_paths(world, robots, SEED)
    runs = [_drive(world, cfg, paths[cfg.name], voc) for cfg in robots]
    frames = sum(r[0] for r in runs)
    fps = frames / sum(r[1][0] for r in runs)
    fps_cpu = frames / sum(r[1][1] for r in runs)
    feats = [kf.features.descriptors for r in runs for kf in r[2]]
    aligner = build_aligner("visual")
    times, ok = [], 0
    for a in runs[0][3]:
        for b in runs[1][3]:
            res = aligner.align(a.public(), b.public())
            times.append(res.runtime_s)
            ok += res.ok
    t0, c0 = time.perf_counter(), time.process_time()
    train_vocabulary(feats, k=10, L=4, seed=0)
    train_s, train_cpu = time.perf_counter() - t0, time.process_time() - c0
    shipped = Path(str(resources.files("roman_sim.align.visual") / "data" / "orb_vocabulary.npz"))
    res = {
        "machine": platform.platform(),
        "python": platform.python_version(),
        "load_average": list(os.getloadavg()),
        "image_size": [640, 480],
        "orb_features": 700,
        "extraction": {
            "frames": frames,
            "fps": fps,
            "ms_per_frame": 1000.0 / fps,
            "fps_cpu_time": fps_cpu,
            "median_features_with_depth": float(np.median([len(d) for d in feats])),
        },
        "pairs": {
            "n": len(times),
            "verified": ok,
            "median_ms": 1000 * float(np.median(times)),
            "p90_ms": 1000 * float(np.percentile(times, 90)),
            "keyframes_per_submap": float(np.mean([len(s.keyframes) for r in runs for s in r[3]])),
        },
        "vocabulary": {
            "shipped_bytes": shipped.stat().st_size,
            "words": voc.n_words,
            "train_s_on_benchmark_descriptors": train_s,
            "train_cpu_s": train_cpu,
            "benchmark_descriptors": int(sum(map(len, feats))),
        },
    }
    if demo:
        res["demo"] = _demo_times()
    if full:
        spec = importlib.util.spec_from_file_location("train_vocabulary", ROOT / "tools" / "train_vocabulary.py")
        assert spec is not None and spec.loader is not None
        trainer = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(trainer)
        train_default = trainer.train_default

        t0 = time.perf_counter()
        train_default()
        res["vocabulary"]["full_retrain_s"] = time.perf_counter() - t0
    if not quick:
        write_json(OUT, res)
    return res


if __name__ == "__main__":
    flags = {f: f"--{f}" in sys.argv for f in ("quick", "full", "demo")}
    print(json.dumps(main(**flags), indent=2))
