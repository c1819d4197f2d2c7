"""Benchmark of world generation: time and model memory of a 200 x 200 m forest (>= 1000 objects).

Run: ``python benchmarks/bench_world.py`` -> ``benchmarks/out/bench_world.json``.
Also times the tiny test world, export, the ambiguity index and one 640x480 preview render,
and the same forest with textures on, every object part its own texture (``textures: true``
at the default ``texture_px``, the detailed ground at the default ``ground_texel_m``), with
one shared texture per surface kind, and with the plain ground (``ground_texel_m: null``). Times are the
best of a few runs, wall and CPU (CPU is steadier on a shared machine).
"""

from __future__ import annotations

import json
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

# isort: off
import roman_sim  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco

# isort: on
from roman_sim.core.atomic import write_json
from roman_sim.core.config import validate_model
from roman_sim.world import WorldSpec, export_world, generate, load_world_spec
from roman_sim.world.ambiguity import ambiguity_index
from roman_sim.world.preview import render_view

OUT = Path(__file__).resolve().parent / "out" / "bench_world.json"
REPEATS = 3


def _best_of(fn, repeats: int = REPEATS) -> tuple[float, object]:  # noqa: ANN001
    best, result = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def _textured(forest: WorldSpec, **appearance: object) -> dict:
    """Generation time and memory of the forest with textures on (``appearance`` on top)."""
    data = forest.model_dump(mode="json")
    data["appearance"] = {**data["appearance"], "textures": True, **appearance}
    spec = validate_model(WorldSpec, data)
    wall, cpu, world = float("inf"), float("inf"), None
    for _ in range(REPEATS):
        t0, c0 = time.perf_counter(), time.process_time()
        world = generate(spec, 0)
        wall, cpu = min(wall, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
    assert world is not None
    m = world.model
    with tempfile.TemporaryDirectory() as tmp:
        export_s, _ = _best_of(lambda: export_world(world, tmp), 1)
    return {
        "appearance": data["appearance"] | {"lighting": "noon"},
        "textures": int(m.ntex),
        "texture_mb": round(m.ntexdata / 2**20, 2),
        "model_buffer_mb": round(m.nbuffer / 2**20, 2),
        "generate_s": round(wall, 3),
        "generate_cpu_s": round(cpu, 3),
        "export_s": round(export_s, 3),
    }


def main() -> dict:
    machine = {
        "python": sys.version.split()[0],
        "mujoco": mujoco.__version__,
        "cpu": platform.processor() or platform.machine(),
    }
    figures: dict = {"machine": machine}
    forest = load_world_spec("forest")
    gen_s, world = _best_of(lambda: generate(forest, 0))
    m = world.model
    figures["forest_200m"] = {
        "objects": len(world.truth.objects),
        "geoms": int(m.ngeom),
        "meshes": int(m.nmesh),
        "mesh_faces": int(m.nmeshface),
        "hfield": [int(m.hfield_nrow[0]), int(m.hfield_ncol[0])],
        "generate_s": round(gen_s, 3),
        "model_buffer_mb": round(m.nbuffer / 2**20, 2),
        "target_generate_s": 10.0,
    }
    figures["forest_200m_textured_per_instance"] = _textured(forest)
    figures["forest_200m_textured_per_surface_256"] = _textured(forest, texture_scope="surface", texture_px=256)
    figures["forest_200m_textured_plain_ground"] = _textured(forest, ground_texel_m=None)
    tiny_s, _ = _best_of(lambda: generate(load_world_spec("tiny"), 0))
    figures["tiny_generate_s"] = round(tiny_s, 3)
    with tempfile.TemporaryDirectory() as tmp:
        export_s, _ = _best_of(lambda: export_world(world, tmp), 1)
    figures["forest_export_s"] = round(export_s, 3)
    amb_s, amb = _best_of(lambda: ambiguity_index(world.truth, n_places=50), 1)
    figures["forest_ambiguity_index"] = {"value": round(float(amb), 4), "n_places": 50, "seconds": round(amb_s, 3)}
    render_view(world, 640, 480)  # warm up the GL context
    rgb_s, _ = _best_of(lambda: render_view(world, 640, 480))
    figures["forest_preview_rgb_640x480_s"] = round(rgb_s, 3)
    figures["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    figures["load_average_1m"] = round(os.getloadavg()[0], 1)
    write_json(OUT, figures)
    return figures


if __name__ == "__main__":
    sys.stdout.write(json.dumps(main(), indent=2) + "\n")
