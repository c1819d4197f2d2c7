"""The exported world opens in MuJoCo's own interactive viewer (on a virtual X display)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time

import pytest

from roman_sim.world import export_world, generate, load_world_spec

# Load the exported MJCF in plain MuJoCo, open MuJoCo's viewer on it and let it draw frames.
VIEWER_SCRIPT = """
import os, sys, time
import mujoco, mujoco.viewer
model = mujoco.MjModel.from_xml_path(sys.argv[1])
data = mujoco.MjData(model)
with mujoco.viewer.launch_passive(model, data) as v:
    for _ in range(20):
        mujoco.mj_step(model, data)
        v.sync()
        time.sleep(0.05)
    assert v.is_running()
print(model.ngeom, "viewer ran", flush=True)
os._exit(0)  # GLFW can crash in interpreter teardown after the viewer closed; that is not the world's fault
"""


@pytest.mark.skipif(shutil.which("Xvfb") is None, reason="needs Xvfb (apt-get install xvfb)")
def test_export_opens_in_mujoco_viewer(tmp_path):
    export_world(generate(load_world_spec("tiny"), 0), tmp_path / "w")
    xml = tmp_path / "w" / "world.xml"
    display = f":{90 + os.getpid() % 9}"
    xvfb = subprocess.Popen(
        ["Xvfb", display, "-screen", "0", "800x600x24"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        time.sleep(1.0)
        env = {**os.environ, "DISPLAY": display, "MUJOCO_GL": "glfw"}
        env.pop("PYOPENGL_PLATFORM", None)
        proc = subprocess.run(
            [sys.executable, "-c", VIEWER_SCRIPT, str(xml)], env=env, capture_output=True, text=True, timeout=60
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
        assert proc.stdout.split()[-2:] == ["viewer", "ran"], proc.stdout
    finally:
        xvfb.kill()
        xvfb.wait()
