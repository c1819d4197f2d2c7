"""``roman-sim view`` on the smoke run, read back with rerun's own reader: entities and counts
checked against the run's files (world truth, maps, submaps, alignments, posegraph.json)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.mapping.io import load_segment_map, load_submaps
from roman_sim.viz import recording_contents, write_run_view

IMAGES = 4


@pytest.fixture(scope="module")
def smoke_view(smoke_run, tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("view") / "smoke.rrd"
    result = write_run_view(smoke_run.run_dir, out, max_images=IMAGES)
    return result, recording_contents(out)


def test_world_and_trajectories(smoke_run, smoke_view) -> None:
    from roman_sim.world import generate

    _, contents = smoke_view
    sc = smoke_run.scenario
    n_objects = len(generate(sc.world.spec(), sc.seed).truth.objects)
    assert contents["/world/objects"]["Boxes3D:centers"] == [n_objects]
    assert contents["/world/objects"]["Boxes3D:quaternions"] == [n_objects]
    assert contents["/world/terrain"]["Mesh3D:vertex_positions"][0] > 0
    for robot in ("a", "b"):
        for variant in ("truth", "odometry", "roman", "oracle"):
            assert contents[f"/world/trajectories/{robot}/{variant}"]["LineStrips3D:strips"] == [1]


def test_maps_and_submaps(smoke_run, smoke_view) -> None:
    _, contents = smoke_view
    for robot in ("a", "b"):
        smap = load_segment_map(smoke_run.run_dir / "maps" / f"{robot}.npz")
        assert contents[f"/world/maps/{robot}/centroids"]["Points3D:positions"] == [len(smap)]
        n_points = sum(len(s.points) for s in smap.segments)
        assert contents[f"/world/maps/{robot}/points"]["Points3D:positions"] == [n_points]
        subs = load_submaps(smoke_run.run_dir / "submaps" / f"{robot}.npz")
        logged = sorted(
            int(e.rsplit("/", 1)[1]) for e in contents if e.startswith(f"/world/submaps/{robot}/") and e.count("/") == 4
        )
        assert logged == [s.index for s in subs]
        for s in subs:
            assert contents[f"/world/submaps/{robot}/{s.index}/segments"]["Points3D:positions"] == [len(s)]


def test_loop_closures_agree_with_the_pose_graph(smoke_run, smoke_view) -> None:
    result, contents = smoke_view
    sc = smoke_run.scenario
    rows = json.loads((smoke_run.run_dir / "alignments.json").read_text())["alignments"]
    candidates = [
        r
        for r in rows
        if r["method"] == sc.posegraph_method
        and r["T_a_b"] is not None
        and r["n_associations"] >= sc.posegraph.lc_association_thresh
    ]
    pg = json.loads((smoke_run.run_dir / "posegraph.json").read_text())[sc.posegraph_method]
    n = {
        v: sum(contents.get(f"/world/loop_closures/{v}", {}).get("LineStrips3D:strips", [0]))
        for v in ("correct", "wrong", "rejected")
    }
    assert n == result.closures
    assert n["correct"] + n["wrong"] + n["rejected"] == len(candidates) == pg["closures_used"]
    assert n["correct"] + n["wrong"] == pg["inliers"]
    assert n["correct"] > 0


def test_camera_images_on_the_timeline(smoke_view) -> None:
    result, contents = smoke_view
    assert result.images == {"a": IMAGES, "b": IMAGES}
    for robot in ("a", "b"):
        cam = f"/world/robots/{robot}/camera"
        assert contents[cam]["Pinhole:image_from_camera"] == [1]
        assert len(contents[cam]["Transform3D:translation"]) == IMAGES
        for child, comp in (
            ("rgb", "Image:buffer"),
            ("depth", "DepthImage:buffer"),
            ("mask", "SegmentationImage:buffer"),
        ):
            assert len(contents[f"{cam}/{child}"][comp]) == IMAGES


def test_cli_writes_and_reports(smoke_run, tmp_path: Path) -> None:
    out = tmp_path / "v.rrd"
    res = CliRunner().invoke(app, ["view", str(smoke_run.run_dir), "--out", str(out), "--images", "0", "--open"])
    assert res.exit_code == 0, res.output
    assert out.is_file() and "recording:" in res.output
    assert not any(e.startswith("/world/robots") for e in recording_contents(out))
    bad = CliRunner().invoke(app, ["view", str(tmp_path)])
    assert bad.exit_code == 1 and "not a run folder" in bad.output
