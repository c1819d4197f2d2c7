"""No stage module renders a frame, builds a segmenter, plans robots or draws: the report's figures are drawn by
``roman_sim.report`` from the saved outputs (the maps stage keeps the camera frame the snapshot shows). What
renders and maps a robot is the maps stage's worker job, run in the workers (``worker_preload``)."""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

import numpy as np

import roman_sim.pipeline.stages as stages_pkg
from roman_sim.pipeline.experiment import Experiment
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.pipeline.stages import STAGES

#: Modules a stage never imports: renderers, plotting, the simulator.
FORBIDDEN_MODULES = ("mujoco", "matplotlib", "pyrender", "OpenGL", "roman_sim.sim", "roman_sim.report.maskview")
#: Names a stage never imports: renderers, frame sources, segmenter and encoder builders, drawing into files.
FORBIDDEN_NAMES = {
    "render_trajectory",
    "SensorRenderer",
    "robot_sources",
    "plan_paths",
    "trajectory_along",
    "build_segmenter",
    "build_segmenter_for",
    "build_encoder",
    "build_encoder_for",
    "plot_frontend_grades",
    "plot_masks",
    "masks_files",
    "save_png",
    "save_figure",
    "figure_files",
    "figure",
}
#: The world stage's one call into the world package, its type and the world's pickled form (shipped to workers).
ALLOWED_WORLD = {"generate", "World", "PickledWorld"}


def _imports(path: Path) -> list[tuple[str, str]]:
    """(module, name) of every import in the file, at any depth (name "" for ``import module``)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(a.name, "") for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            out += [(node.module, a.name) for a in node.names]
    return out


def test_stage_modules_import_no_renderer_segmenter_or_plotting() -> None:
    (maps,) = (s for s in STAGES if s.name == "maps")  # its worker job renders and maps one robot
    jobs = {m for m in maps.worker_preload if m.startswith(stages_pkg.__name__)} - {type(maps).__module__}
    assert jobs == {f"{stages_pkg.__name__}.{m}" for m in ("maps_job", "maps_robot", "maps_input")}
    files = [
        f
        for f in sorted(Path(stages_pkg.__file__).parent.glob("*.py"))
        if f"{stages_pkg.__name__}.{f.stem}" not in jobs
    ]
    assert {"maps.py", "report.py", "world.py"} <= {f.name for f in files}
    bad = []
    for f in files:
        for module, name in _imports(f):
            if module.startswith(FORBIDDEN_MODULES) or name in FORBIDDEN_NAMES:
                bad.append(f"{f.name}: {module}.{name}")
            if module.startswith("roman_sim.world") and name not in ALLOWED_WORLD:
                bad.append(f"{f.name}: {module}.{name}")
    assert not bad, bad


def test_the_report_draws_the_snapshot_and_grades_from_the_maps_stage_output(tmp_path, monkeypatch) -> None:
    sc = load_scenario("smoke", ["robots.0.max_duration_s=20", "robots.1.max_duration_s=20"])
    run_dir = tmp_path / "run"
    Experiment(sc, run_dir).run()
    files = {p.relative_to(run_dir).as_posix() for p in run_dir.rglob("*") if p.is_file()}
    assert {"maps/snapshot.npz", "maps/frontend.json", "plots/frontend.png", "plots/segments_on_image.png"} <= files
    from roman_sim.report.snapshot import load_snapshot

    snap = load_snapshot(run_dir / "maps/snapshot.npz")
    assert snap.robot == sc.robots[0].name and snap.rgb.shape == (*snap.masks.shape[1:], 3) and len(snap.masks) > 0
    assert len(snap.labels) == len(snap.masks) and any(label is not None for label in snap.labels)
    pngs = {n: (run_dir / n).read_bytes() for n in ("plots/frontend.png", "plots/segments_on_image.png")}
    for n in pngs:
        (run_dir / n).unlink()
    shutil.rmtree(run_dir / "recordings", ignore_errors=True)

    def no_render(*args: object, **kwargs: object) -> None:
        raise AssertionError("the report rendered a frame")

    from roman_sim.sim import render

    monkeypatch.setattr(render.SensorRenderer, "__init__", no_render)
    Experiment(sc, run_dir, from_stage="report").run()  # maps loaded; nothing rendered
    assert {n: (run_dir / n).read_bytes() for n in pngs} == pngs


def test_the_snapshot_frame_is_the_one_in_sight_of_the_most_segments() -> None:
    from types import SimpleNamespace

    from roman_sim.mapping.mapper import SegmentMap
    from roman_sim.pipeline.stages.maps_robot import busiest_frame

    segs = [SimpleNamespace(first_seen=a, last_seen=b) for a, b in ((0.0, 1.0), (1.0, 2.0), (1.0, 3.0), (3.0, 3.0))]
    smap = SegmentMap("a", segs, times=np.array([0.0, 1.0, 2.0, 3.0]))  # in sight: 1, 3, 2, 2
    assert busiest_frame(smap) == 1
    smap.segments = segs[2:]  # in sight: 0, 1, 1, 2
    assert busiest_frame(smap) == 3


def test_a_snapshot_keeps_image_masks_and_majority_objects(tmp_path) -> None:
    from roman_sim.core.sensors import Frame, FrameTruth, Intrinsics
    from roman_sim.report.snapshot import FrameSnapshot, load_snapshot, save_snapshot

    ids = np.full((6, 10), -1, dtype=np.int32)
    ids[:, :4] = 7
    ids[:3, 4:] = 9
    rgb = np.arange(6 * 10 * 3, dtype=np.uint8).reshape(6, 10, 3)
    frame = Frame(
        "a",
        4,
        2.5,
        rgb,
        np.ones((6, 10), np.float32),
        np.eye(4),
        np.eye(4),
        Intrinsics(10, 6, 5.0, 5.0, 4.5, 2.5),
        FrameTruth(ids, np.eye(4)),
    )
    left, top_right, bottom_right = np.zeros((3, 6, 10), dtype=bool)
    left[:, :5] = True  # 24 pixels of object 7, 3 of object 9
    top_right[:3, 6:] = True
    bottom_right[3:, 6:] = True  # terrain only
    snap = FrameSnapshot.of(frame, [left, top_right, bottom_right], "configured")
    assert snap.labels == ["7", "9", None]
    assert snap.title.startswith("robot a at t = 2.5 s: 3 masks of the configured segmenter")
    save_snapshot(tmp_path / "s.npz", snap)
    back = load_snapshot(tmp_path / "s.npz")
    np.testing.assert_array_equal(back.rgb, rgb)
    np.testing.assert_array_equal(back.masks, np.stack([left, top_right, bottom_right]))
    assert (back.robot, back.t, back.labels, back.segmenter) == ("a", 2.5, ["7", "9", None], "configured")
