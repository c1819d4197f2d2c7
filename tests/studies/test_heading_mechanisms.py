"""Heading mechanisms acting on rendered frames of tiny worlds, and each switch removing its effect.

Frames are rendered with MuJoCo from body poses placed by hand around one object (ground
truth from the generated world), at 160 x 120; the switches are the registry's overrides
(``roman_sim.studies.mechanisms``) applied through the scenario override machinery.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

# isort: off
import roman_sim  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)

# isort: on
import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.core.geometry import make_T, rot_z
from roman_sim.core.overrides import apply_overrides
from roman_sim.core.sensors import Frame, FrameTruth
from roman_sim.frontend.components import SegmenterEntry
from roman_sim.frontend.segmenter import SEGMENTERS, SegmenterConfig, SimulatedSegmenter
from roman_sim.frontend.whole_surface import WholeSurface
from roman_sim.mapping.observation import observe
from roman_sim.mapping.tracker import MappingConfig, Observation
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.render import SensorRenderer
from roman_sim.studies.mechanisms import MECHANISMS, check_mechanisms, mechanism_overrides, switchable
from roman_sim.world import World, WorldSpec, generate, load_world_spec

W, H = 160, 120


def _world(families: list[dict[str, Any]], side_m: float = 30.0, **updates: Any) -> World:
    data = load_world_spec("tiny").model_dump(mode="json")
    data.update(extent_m=[side_m, side_m], families=families)
    data = apply_overrides(data, [f"{k}={v}" for k, v in updates.items()], source="test world")
    return generate(validate_model(WorldSpec, data, "test world"), 0)


@pytest.fixture(scope="module")
def car_world() -> World:
    """One car (3.6 x 1.5 x 1.2 m) on a 30 x 30 m patch with a loop road."""
    w = _world([{"name": "car", "density": 20}])
    assert [o.family for o in w.truth.objects] == ["car"]
    return w


def _frame(world: World, cam: CameraConfig, T_world_body: np.ndarray, index: int, rgb: bool = False) -> Frame:
    """The frame a robot at ``T_world_body`` renders (no drift: odometry = truth)."""
    T_bc = cam.T_body_cam()
    r = SensorRenderer(world, cam, rgb=rgb)
    try:
        image, depth, ids = r.render(T_world_body @ T_bc)
    finally:
        r.close()
    return Frame(
        "a", index, float(index), image, depth, T_world_body, T_bc, cam.intrinsics(), FrameTruth(ids, T_world_body)
    )


def _facing(world: World, oid: int, bearing_rad: float, dist_m: float) -> np.ndarray:
    """Body pose ``dist_m`` from object ``oid`` along ``bearing_rad`` (world), looking at it."""
    c = world.truth.objects[oid].centroid
    xy = c[:2] + dist_m * np.array([math.cos(bearing_rad), math.sin(bearing_rad)])
    z = float(world.truth.terrain.height_at(xy[0], xy[1]))
    return make_T(rot_z(bearing_rad + math.pi), [xy[0], xy[1], z])


def _long_axis_bearing(world: World, oid: int) -> float:
    """Bearing (rad) of the object's longest horizontal box axis."""
    o = world.truth.objects[oid]
    R = o.obb_T_world[:3, :3]
    horiz = [k for k in range(3) if abs(R[2, k]) < 0.5]
    k = max(horiz, key=lambda j: o.obb_extents[j])
    return math.atan2(R[1, k], R[0, k])


def _obs_of(frame: Frame, oid: int, reshape: Callable[..., list[Observation]] | None = None) -> Observation:
    seg = SimulatedSegmenter(SegmenterConfig.model_validate({**_PERFECT}), seed=0)
    obs = observe(frame, seg.segment(frame), MappingConfig(), None)
    if reshape is not None:
        obs = reshape(frame, obs)
    mine = [o for o in obs if o.truth and max(o.truth, key=lambda i: o.truth[i]) == oid]
    assert len(mine) == 1, f"object {oid}: {len(mine)} observations"
    return mine[0]


#: The perfect segmenter, with room for a close object that fills most of a small image.
_PERFECT = SEGMENTERS.get("perfect").model_copy(update={"max_area_div": 1.2}).model_dump()


# -- the registry -----------------------------------------------------------------------------
def test_unknown_mechanism_names_the_field_and_the_allowed_names() -> None:
    with pytest.raises(ConfigError) as err:
        check_mechanisms(["partial_views", "shadows"], "--mechanism")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("--mechanism: unknown mechanism 'shadows'")
    assert all(n in msg for n in switchable())
    with pytest.raises(ConfigError, match="a mechanism is named twice"):
        check_mechanisms(["occlusion", "occlusion"])


def test_every_switch_is_a_valid_scenario_override() -> None:
    """Each switchable mechanism's overrides load on the bundled opposite-direction scenario."""
    from roman_sim.core.yamlio import read_yaml
    from roman_sim.pipeline.scenario import Scenario, resolve_scenario_path

    data = read_yaml(resolve_scenario_path("opposite_direction"))
    base = validate_model(Scenario, data, "opposite_direction")
    for name in switchable():
        sc = validate_model(Scenario, apply_overrides(data, mechanism_overrides(name, data)), name)
        assert sc.config_hash() != base.config_hash(), name
    road = validate_model(Scenario, apply_overrides(data, mechanism_overrides("road_side", data)), "road_side")
    assert [r.path.lateral_offset_m for r in road.robots] == [(0.0, 0.0), (0.0, 0.0)]


def test_a_switch_on_a_front_end_that_cannot_honour_it_fails_in_one_line() -> None:
    data = {"frontend": {"encoder": "image", "segmenter": "image"}, "robots": []}
    for name, field in (("descriptor_view", "frontend.encoder"), ("segmenter_view", "frontend.segmenter")):
        with pytest.raises(ConfigError, match=rf"^mechanisms: {name} .* {field} 'image' has none"):
            mechanism_overrides(name, data)
    for name in ("partial_views", "one_sided_visibility", "occlusion", "range_truncation", "image_edges"):
        with pytest.raises(ConfigError, match=f"{name} .* sequence"):
            mechanism_overrides(name, {"robots": [{"name": "a", "source": {"path": "x"}}]})


def test_the_docs_table_lists_every_mechanism() -> None:
    from pathlib import Path

    page = (Path(__file__).parents[2] / "docs" / "heading_mechanisms.md").read_text()
    page = page.split("## The attribution study", 1)[0]  # the mechanisms' table, not the study's
    rows = [ln.split("|")[1].strip().strip("`") for ln in page.splitlines() if ln.startswith("| `")]
    assert rows == list(MECHANISMS)


# -- partial views --------------------------------------------------------------------------
def test_partial_views_move_the_centroid_between_opposite_views_and_whole_surfaces_do_not(car_world: World) -> None:
    """Seen side-on from opposite sides, the car's observed centroid moves by most of its width toward
    each camera; with the counterfactual (whole surfaces) the two views give the same points."""
    o = car_world.truth.objects[0]
    cam = CameraConfig(width=W, height=H)
    side = _long_axis_bearing(car_world, 0) + math.pi / 2
    frames = [_frame(car_world, cam, _facing(car_world, 0, side + k * math.pi, 4.0), k) for k in (0, 1)]
    width = float(min(o.obb_extents[:2]))  # the box axis along the view (side-on)
    c = [_obs_of(f, 0).points.mean(axis=0) for f in frames]
    toward = np.array([math.cos(side), math.sin(side)])
    shift = float((c[0] - c[1])[:2] @ toward)  # view 0 stands on +toward, so its points lie on that side
    assert 0.4 * width < shift < 1.0 * width, (shift, width)
    whole = WholeSurface(car_world, MappingConfig().voxel)
    w = [_obs_of(f, 0, whole).points for f in frames]
    np.testing.assert_allclose(w[0], w[1], atol=1e-9)
    assert np.linalg.norm(w[0].mean(axis=0)[:2] - o.centroid[:2]) < 0.1 * float(max(o.obb_extents))


def test_whole_surface_points_follow_the_drifted_pose(car_world: World) -> None:
    """With odometry drift the whole surface lands where the robot believes it is (odometry frame)."""
    cam = CameraConfig(width=W, height=H)
    T_wb = _facing(car_world, 0, 0.3, 4.0)
    f = _frame(car_world, cam, T_wb, 0)
    drift = make_T(rot_z(0.2), [1.0, -2.0, 0.1])
    drifted = Frame(f.robot, f.index, f.t, f.rgb, f.depth, drift @ T_wb, f.T_body_cam, f.intrinsics, f.truth)
    whole = WholeSurface(car_world, MappingConfig().voxel)
    p0, p1 = _obs_of(f, 0, whole).points, _obs_of(drifted, 0, whole).points
    np.testing.assert_allclose(p1.mean(axis=0), (drift[:3, :3] @ p0.mean(axis=0)) + drift[:3, 3], atol=0.03)


def test_whole_surface_refuses_frames_without_truth(car_world: World) -> None:
    f = _frame(car_world, CameraConfig(width=W, height=H), _facing(car_world, 0, 0.0, 4.0), 0)
    with pytest.raises(ConfigError, match="^mapping.whole_surface: frame 0 of robot a has no ground truth"):
        WholeSurface(car_world, 0.05)(f.public(), [])


def test_a_mapper_without_the_world_refuses_whole_surface() -> None:
    from roman_sim.mapping.mapper import Mapper

    with pytest.raises(ConfigError, match=r"^mapping.whole_surface: .*allowed here: false"):
        Mapper(MappingConfig(whole_surface=True), SimulatedSegmenter(SegmenterConfig(), 0))


# -- the segmenter's view sectors -------------------------------------------------------------
def test_segmenter_view_sectors_change_the_masks_with_the_view_and_the_switch_removes_them(car_world: World) -> None:
    """With half the circle in each failure sector the car's mask count and area change with the
    bearing; the switch (view_split_frac = partial_frac = 0) gives one whole mask from every side."""
    cam = CameraConfig(width=W, height=H)
    frames = [_frame(car_world, cam, _facing(car_world, 0, k * math.pi / 4, 4.5), k) for k in range(8)]
    data = {
        "frontend": {
            "segmenter": {"name": "fastsam", "params": {**_PERFECT, "view_split_frac": 0.5, "partial_frac": 0.5}}
        }
    }
    off = apply_overrides(data, mechanism_overrides("segmenter_view", data))

    def masks(entry: dict[str, Any]) -> list[tuple[int, float]]:
        cfg = SegmenterConfig.model_validate(validate_model(SegmenterEntry, entry, "seg").params)
        seg = SimulatedSegmenter(cfg, seed=0)
        out = []
        for f in frames:
            ms = [m for m in seg.segment(f) if 0 in m.object_ids]
            true_px = int((np.asarray(f.truth.object_ids) == 0).sum())
            out.append((len(ms), sum(int(m.pixels.sum()) for m in ms) / true_px))
        return out

    on = masks(data["frontend"]["segmenter"])
    assert len({n for n, _ in on}) > 1 or max(a for _, a in on) - min(a for _, a in on) > 0.2, on
    switched = masks(off["frontend"]["segmenter"])
    assert all(n == 1 for n, _ in switched), switched
    assert max(a for _, a in switched) - min(a for _, a in switched) < 0.1, switched


# -- road side --------------------------------------------------------------------------------
def test_road_side_changes_the_distance_to_a_roadside_object_and_the_centre_line_does_not() -> None:
    """Two robots driving the loop in opposite directions, each keeping to its right, pass a roadside
    object at depths that differ by about their lateral separation; on the centre line the depths agree."""
    from roman_sim.sim.robot import RobotConfig, plan_paths

    world = _world([{"name": "boulder", "density": 200}], side_m=40.0)
    cam = CameraConfig(width=W, height=H)
    robots = [
        {"name": "a", "path": {"kind": "road", "road_index": 0, "lateral_offset_m": [-1.4, -1.0]}},
        {"name": "b", "path": {"kind": "reverse_of", "of": "a", "lateral_offset_m": [-1.4, -1.0]}},
    ]
    data = {"robots": robots}
    off = apply_overrides(data, mechanism_overrides("road_side", data))

    def depth_gaps(robot_data: list[dict[str, Any]]) -> tuple[float, list[float]]:
        cfgs = [validate_model(RobotConfig, r, r["name"]) for r in robot_data]
        paths = plan_paths(world, cfgs, seed=0)
        from scipy.spatial import cKDTree

        sep = float(np.median(cKDTree(paths["b"].xy).query(paths["a"].xy[::10])[0]))
        road = paths["a"].base.xy if paths["a"].base is not None else paths["a"].xy  # the centre line
        gaps = []
        for o in world.truth.objects:
            d = np.linalg.norm(road - o.centroid[:2], axis=1)
            if not 2.5 < d.min() < 5.5 or len(gaps) == 6:
                continue
            depths = []
            for name in ("a", "b"):
                p = paths[name].xy
                i = int(np.argmin(np.linalg.norm(p - o.centroid[:2], axis=1)))
                bearing = math.atan2(p[i, 1] - o.centroid[1], p[i, 0] - o.centroid[0])
                dist = float(np.linalg.norm(p[i] - o.centroid[:2]))
                f = _frame(world, cam, _facing(world, o.id, bearing, dist), 0)
                pix = (np.asarray(f.truth.object_ids) == o.id) & (f.depth > 0)
                depths.append(float(np.median(f.depth[pix])) if pix.any() else math.nan)
            gaps.append(abs(depths[0] - depths[1]))
        return sep, [g for g in gaps if not math.isnan(g)]

    sep_on, gaps_on = depth_gaps(robots)
    sep_off, gaps_off = depth_gaps(off["robots"])
    assert len(gaps_on) >= 2 and len(gaps_off) >= 2
    assert 1.6 < sep_on < 3.0 and sep_off < 0.05
    assert np.median(gaps_on) > 0.5 * sep_on, gaps_on
    assert max(gaps_off) < 0.15, gaps_off


# -- field of view and depth range --------------------------------------------------------------
def test_field_of_view_switch_widens_what_one_frame_sees(car_world: World) -> None:
    """From the same pose, the weakened mechanism's camera sees objects the default one does not."""
    from roman_sim.sim.camera import CameraConfig as C

    world = _world([{"name": "boulder", "density": 80}], side_m=40.0)
    data = {"robots": [{"name": "a", "camera": {"width": W, "height": H}}], "mapping": {}}
    off = apply_overrides(data, mechanism_overrides("field_of_view", data))
    wide = C.model_validate(off["robots"][0]["camera"])
    assert wide.hfov_deg == 150.0 and off["mapping"]["max_depth_m"] == wide.max_depth_m == 15.0
    T = make_T(rot_z(0.4), [0.0, 0.0, float(world.truth.terrain.height_at(0.0, 0.0))])
    seen = []
    for cam in (C(width=W, height=H), wide):
        f = _frame(world, cam, T, 0)
        ids = np.asarray(f.truth.object_ids)[(f.depth > 0) & (f.depth <= cam.max_depth_m)]
        seen.append(set(np.unique(ids[ids >= 0]).tolist()))
    assert seen[0] < seen[1], seen


# -- the sun ------------------------------------------------------------------------------------
def test_the_sun_lights_opposite_sides_differently_and_a_sun_free_world_does_not() -> None:
    """The car's two long sides, rendered in RGB, differ in brightness under the sun (one faces it);
    in the sun-free world (the switch's world overrides) they differ far less."""
    from roman_sim.core.yamlio import parse_yaml

    def brightness_gap(world: World) -> float:
        cam = CameraConfig(width=W, height=H)
        side = _long_axis_bearing(world, 0) + math.pi / 2
        vals = []
        for k in (0, 1):
            f = _frame(world, cam, _facing(world, 0, side + k * math.pi, 4.0), k, rgb=True)
            pix = np.asarray(f.truth.object_ids) == 0
            assert f.rgb is not None and pix.sum() > 200
            vals.append(float(f.rgb[pix].mean()))
        return abs(vals[0] - vals[1])

    side = _long_axis_bearing(_world([{"name": "car", "density": 20}]), 0) + math.pi / 2
    lit = {
        "appearance.lighting.azimuth_deg": round(math.degrees(side) % 360.0, 3),
        "appearance.lighting.elevation_deg": 20.0,
    }
    sunny = _world([{"name": "car", "density": 20}], **lit)
    data = {"world": {"overrides": lit}, "robots": []}
    ovr = mechanism_overrides("sun", data)
    merged = parse_yaml(ovr[0].split("=", 1)[1], "sun overrides")
    assert merged["appearance.lighting.sun"] == 0.0 and merged["appearance.lighting.elevation_deg"] == 20.0
    dark = _world([{"name": "car", "density": 20}], **merged)
    assert brightness_gap(sunny) > 3 * max(brightness_gap(dark), 1.0)


# -- the descriptors' view dependence ----------------------------------------------------------
def test_descriptor_view_dependence_separates_opposite_views_and_the_switch_removes_it(car_world: World) -> None:
    """The simulated encoder, fed the car's observations from rendered frames: descriptors from
    opposite sides are less alike than descriptors from one side; with ``descriptor_view`` off
    (the registry's override on the front end) they are as alike as from one side."""
    from roman_sim.frontend.components import FrontEndConfig, build_encoder

    cam = CameraConfig(width=W, height=H)
    side = _long_axis_bearing(car_world, 0) + math.pi / 2
    poses = [(k, side + k * math.pi + j * 0.05) for k in (0, 1) for j in range(4)]
    frames = [(k, _frame(car_world, cam, _facing(car_world, 0, b, 4.0 + 0.1 * i), i)) for i, (k, b) in enumerate(poses)]
    data: dict[str, Any] = {"frontend": {}}
    families = {o.id: o.family for o in car_world.truth.objects}

    def cosines(fe_data: dict[str, Any]) -> tuple[float, float]:
        enc = build_encoder(validate_model(FrontEndConfig, fe_data, "frontend"), seed=0, robot="a", families=families)
        seg = SimulatedSegmenter(SegmenterConfig.model_validate(_PERFECT), seed=0)
        descs = []
        for k, f in frames:
            obs = [o for o in observe(f, seg.segment(f), MappingConfig(), enc) if o.truth.most_common(1)[0][0] == 0]
            assert len(obs) == 1 and obs[0].descriptor is not None
            descs.append((k, obs[0].descriptor / np.linalg.norm(obs[0].descriptor)))
        within = [float(a @ b) for i, (ka, a) in enumerate(descs) for kb, b in descs[i + 1 :] if ka == kb]
        across = [float(a @ b) for i, (ka, a) in enumerate(descs) for kb, b in descs[i + 1 :] if ka != kb]
        return float(np.mean(within)), float(np.mean(across))

    within_on, across_on = cosines(data["frontend"])
    off = apply_overrides(data, mechanism_overrides("descriptor_view", data))
    within_off, across_off = cosines(off["frontend"])
    assert across_on < within_on - 0.05, (within_on, across_on)
    assert abs(across_off - within_off) < 0.02, (within_off, across_off)
