"""The sensor layer and the mapper know nothing of the simulator: frames from plain numpy arrays
(no ground truth) are mapped into segments where the objects are, with no MuJoCo or gymnasium import."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

SCRIPT = r"""
import json, sys
import numpy as np
from roman_sim.examples.depth_segmenter import DepthEdgeSegmenter, ShapeEncoder
from roman_sim.core.geometry import make_T
from roman_sim.mapping import Mapper, MappingConfig, SubmapConfig, build_submaps
from roman_sim.mapping.synthetic import T_BODY_CAM, intrinsics, render
from roman_sim.core.sensors import Frame

spheres = [(np.array([4.0, 0.0, 0.4]), 0.4), (np.array([5.0, 1.5, 0.3]), 0.3), (np.array([6.0, -1.5, 0.35]), 0.35)]
intr = intrinsics(160, 120)
mapper = Mapper(MappingConfig(), DepthEdgeSegmenter(), ShapeEncoder())
for i in range(24):
    T_wb = make_T(t=[0.1 * i, 0.0, 0.0])
    depth, _ = render(spheres, T_wb @ T_BODY_CAM, intr, ground=False)  # plain numpy arrays
    mapper.process(Frame("a", i, i / 6.0, None, depth.astype(np.float32), T_wb, T_BODY_CAM, intr))
smap = mapper.finish()
subs = build_submaps(smap, SubmapConfig())
print(json.dumps({"centers": [s.center.tolist() for s in smap.segments], "no_truth": smap.truth is None,
                  "submaps_without_truth": all(s.truth is None for s in subs), "n_submaps": len(subs),
                  "modules": sorted(m for m in ("mujoco", "gymnasium", "pyrender", "OpenGL") if m in sys.modules)}))
"""


def test_frames_without_truth_map_without_the_simulator(tmp_path):
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT], cwd=tmp_path, capture_output=True, text=True, timeout=300, check=True
    ).stdout
    res = json.loads(out)
    assert res["modules"] == []  # neither MuJoCo nor gymnasium (nor a renderer) was imported
    assert res["no_truth"] and res["submaps_without_truth"] and res["n_submaps"] >= 1
    centers = np.asarray(res["centers"])
    truth = [((4.0, 0.0, 0.4), 0.4), ((5.0, 1.5, 0.3), 0.3), ((6.0, -1.5, 0.35), 0.35)]
    assert len(centers) == len(truth)
    for c, r in truth:
        d = np.linalg.norm(centers[:, :2] - np.asarray(c[:2]), axis=1)
        k = int(np.argmin(d))
        # the mean of the visible front surface lies between the sphere's centre and the camera
        assert d[k] < r and abs(centers[k, 2] - c[2]) < 0.1, (c, centers[k])


def test_importing_the_mapper_does_not_import_the_simulator():
    code = (
        "import sys, roman_sim.mapping.mapper, roman_sim.core.sensors; "
        "print(sorted(m for m in ('mujoco', 'gymnasium') if m in sys.modules))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip() == "[]"
