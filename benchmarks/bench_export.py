"""Export benchmark: frames per second of ``export_scenario`` at 640 x 480, both formats.

Scenario: the bundled ``demo`` (dense 80 x 80 m off-road world), robot ``a`` only, cut to
``n`` frames, at the default 640 x 480 camera. Rendering (RGB, depth, ids, depth noise) is
timed apart from writing (PNG encoding or CDR serialisation, masks, atomic files), from
the exporter's own per-robot timers; ``fps_total`` is frames over both. Also the bytes
written per frame. Writes ``benchmarks/out/export.json``.
Run: ``python benchmarks/bench_export.py [--quick]``.
"""

from __future__ import annotations

import os
import platform
import sys
import tempfile
from pathlib import Path

import roman_sim  # noqa: F401  (headless rendering defaults before mujoco loads)
from roman_sim.core.atomic import write_json
from roman_sim.interop import export_scenario
from roman_sim.pipeline.scenario import load_scenario

OUT = Path(__file__).resolve().parent / "out" / "export.json"
FORMATS = {"tum": {}, "rosbag2_mcap": {"storage": "mcap"}, "rosbag2_sqlite3": {"storage": "sqlite3"}}


def _bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def main(quick: bool = False) -> dict:
    """Run the benchmark and write its figures."""
    n = 10 if quick else 40
    sc = load_scenario(
        "demo", [f"robots.0.max_duration_s={(n - 1) / 6.0}", "robots.0.camera.width=640", "robots.0.camera.height=480"]
    )
    out: dict = {"scenario": "demo", "robot": "a", "image": [640, 480], "formats": {}}
    with tempfile.TemporaryDirectory(prefix="bench_export.") as tmp:
        for key, options in FORMATS.items():
            fmt = "tum" if key == "tum" else "rosbag2"
            res = export_scenario(sc, fmt, Path(tmp) / key, robots=["a"], **options)
            frames = res.robots["a"]["frames"]
            render_s, write_s = res.render_s["a"], res.write_s["a"]
            out["formats"][key] = {
                "frames": frames,
                "fps_total": round(frames / (render_s + write_s), 2),
                "fps_render": round(frames / render_s, 2),
                "fps_write": round(frames / write_s, 2),
                "render_ms_per_frame": round(1000 * render_s / frames, 1),
                "write_ms_per_frame": round(1000 * write_s / frames, 1),
                "kb_per_frame": round(_bytes(Path(tmp) / key / "a") / frames / 1000, 1),
            }
    out["machine"] = {
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
        "note": "2 cores shared with other jobs while measured; compare formats within one run",
    }
    write_json(OUT, out)
    return out


if __name__ == "__main__":
    import json

    sys.stdout.write(json.dumps(main(quick="--quick" in sys.argv), indent=2) + "\n")
