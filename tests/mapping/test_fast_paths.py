"""The mapper's fast paths against their reference paths on rendered frames: the same map, bit for bit.

Fast paths: the oriented box by screened directions (``mapping.obb``), the merge of two
downsampled clouds (``voxels.downsample_union``), the voxel graph of the largest cluster by
packed keys, cached centres and observation labels. The reference run swaps each fast path
for the plain computation it replaces.
"""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.records import to_json
from roman_sim.frontend.components import build_encoder, build_segmenter
from roman_sim.mapping import segment as segment_mod
from roman_sim.mapping import voxels
from roman_sim.mapping.io import save_segment_map
from roman_sim.mapping.mapper import Mapper
from roman_sim.mapping.obb import trimesh_extents
from roman_sim.mapping.submap import build_submaps
from roman_sim.pipeline.scenario import load_scenario
from roman_sim.sim.camera import CameraConfig
from roman_sim.sim.robot import DrivenRun, plan_paths, render_trajectory, trajectory_along
from roman_sim.world import generate


@pytest.fixture(scope="module")
def demo_frames():
    """The first 40 s of the demo's robot a (dense off-road loop), 160 x 120, every frame."""
    sc = load_scenario("demo")
    world = generate(sc.world.spec(), sc.seed)
    cfg = sc.robots[0].model_copy(update={"camera": CameraConfig(width=160, height=120), "render_rgb": False})
    t, T_wb, T_ob = trajectory_along(world, cfg, sc.seed, plan_paths(world, sc.simulated_robots(), sc.seed)["a"])
    n = 240
    frames = list(render_trajectory(world, cfg, sc.seed, DrivenRun(t[:n], T_wb[:n], T_ob[:n])))
    return sc, {o.id: o.family for o in world.truth.objects}, frames


def _map(sc, families, frames, tmp_path, tag):
    fe = sc.frontend
    mapper = Mapper(sc.mapping, build_segmenter(fe, seed=sc.seed, robot="a"), build_encoder(fe, sc.seed, "a", families))
    for f in frames:
        mapper.process(f)
    smap = mapper.finish()
    save_segment_map(tmp_path / f"{tag}.npz", smap)
    subs = build_submaps(smap, sc.submaps)
    return (tmp_path / f"{tag}.npz").read_bytes(), smap, subs


def test_fast_and_reference_paths_make_the_same_map(demo_frames, tmp_path, monkeypatch) -> None:
    sc, families, frames = demo_frames
    calls = {"union": 0, "merged": 0}
    union = voxels.downsample_union

    def counting_union(a, b, voxel, keys_a=None):
        out, keys = union(a, b, voxel, keys_a)
        calls["union"] += 1
        calls["merged"] += len(out) < len(a) + len(b)  # some voxels held a point of each
        if keys is not None:  # the keys handed on are those of the merged points
            np.testing.assert_array_equal(keys, voxels.hash_voxels(out, voxel))
        return out, keys

    monkeypatch.setattr(segment_mod, "downsample_union", counting_union)
    fast = _map(sc, families, frames, tmp_path, "fast")
    assert calls["union"] > 100 and calls["merged"] > 50 and len(fast[1]) >= 10
    with monkeypatch.context() as m:  # every fast path replaced by what it replaces
        m.setattr(
            segment_mod, "downsample_union", lambda a, b, v, k=None: (voxels.downsample(np.vstack([a, b]), v), None)
        )
        m.setattr(segment_mod, "largest_cluster", segment_mod.largest_cluster_reference)
        m.setattr(segment_mod, "oriented_extents", trimesh_extents)
        ref = _map(sc, families, frames, tmp_path, "reference")
    assert fast[0] == ref[0]
    for a, b in zip(fast[1].segments, ref[1].segments, strict=True):
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.extents, b.extents)
        assert a.volume == b.volume and a.truth_counts == b.truth_counts
    for a, b in zip(fast[2], ref[2], strict=True):
        for field in ("centers", "volumes", "extents", "shape", "descriptors", "segment_ids"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_union_of_downsampled_clouds_is_the_downsample_of_both() -> None:
    rng = np.random.default_rng(4)
    for k in range(50):
        a = voxels.downsample(rng.uniform(-3, 3, (int(rng.integers(1, 800)), 3)) + 40.0, 0.05)
        b = voxels.downsample(np.vstack([a[: k * 3], rng.uniform(-3, 3, (200, 3)) + 40.0]), 0.05)
        out, keys = voxels.downsample_union(a, b, 0.05)
        np.testing.assert_array_equal(out, voxels.downsample(np.vstack([a, b]), 0.05))
        np.testing.assert_array_equal(keys, voxels.hash_voxels(out, 0.05))
        again, _ = voxels.downsample_union(out, b, 0.05, keys)  # with the keys handed on
        np.testing.assert_array_equal(again, voxels.downsample(np.vstack([out, b]), 0.05))
    raw = rng.uniform(0, 1, (300, 3))  # not downsampled: the general path
    out, keys = voxels.downsample_union(raw, raw, 0.1)
    np.testing.assert_array_equal(out, voxels.downsample(np.vstack([raw, raw]), 0.1))
    assert keys is None


def test_largest_cluster_by_keys_is_the_k_d_tree_one() -> None:
    rng = np.random.default_rng(6)
    for k in range(40):
        blobs = [rng.normal(c, 0.15, (int(rng.integers(5, 200)), 3)) for c in rng.uniform(-3, 3, (4, 3))]
        pts = np.vstack(blobs) + (0.0 if k % 2 else 1e5)  # far from the origin too
        np.testing.assert_array_equal(
            segment_mod.largest_cluster(pts, 0.25), segment_mod.largest_cluster_reference(pts, 0.25)
        )
    tie = np.array([[0.0, 0, 0], [0.1, 0, 0], [5.0, 0, 0], [5.1, 0, 0]])  # two equal clusters: the same one
    np.testing.assert_array_equal(
        segment_mod.largest_cluster(tie, 0.25), segment_mod.largest_cluster_reference(tie, 0.25)
    )


def test_front_end_grades_and_masks_match_their_reference_paths(demo_frames, monkeypatch) -> None:
    """Segmenter (OpenCV morphology, shared object table) and grader (one eroded label image)
    against the scipy filters and the per-object grading, frame by frame."""
    from scipy import ndimage

    from roman_sim.evaluation.grader import FrontEndGrader
    from roman_sim.frontend import frame_objects as fo_mod
    from roman_sim.frontend import mask_noise
    from roman_sim.frontend import segmenter as seg_mod

    sc, families, frames = demo_frames
    fast_seg = build_segmenter(sc.frontend, seed=sc.seed, robot="a")
    fast, ref = FrontEndGrader(families, seed=1), FrontEndGrader(families, seed=1)
    ref._grade_masks = ref._grade_masks_reference  # type: ignore[method-assign]
    masks_fast = []
    for f in frames:
        masks = fast_seg.segment(f)
        masks_fast.append(masks)
        fast.add(f, masks, [])  # the segmenter's object table, handed on
        ref.add(f, masks, [])
    assert to_json(fast.seg) == to_json(ref.seg)
    assert fast.seg.matched > 200 and fast.seg.touching_pairs > 50 and fast.seg.under_segmented > 0

    with monkeypatch.context() as m:
        m.setattr(mask_noise, "boundary_band", mask_noise.boundary_band_reference)
        m.setattr(seg_mod, "erode_mask", lambda pix, k: ndimage.binary_erosion(pix, structure=k, border_value=0))
        m.setattr(fo_mod, "_recent", fo_mod.deque(maxlen=0))  # no table kept: each caller builds its own
        ref_seg = build_segmenter(sc.frontend, seed=sc.seed, robot="a")
        for f, masks in zip(frames, masks_fast, strict=True):
            again = ref_seg.segment(f)
            assert [(a.bbox, a.object_ids) for a in masks] == [(b.bbox, b.object_ids) for b in again]
            for a, b in zip(masks, again):
                np.testing.assert_array_equal(a.pixels, b.pixels)


def test_label_erosion_matches_the_per_label_reference(demo_frames) -> None:
    from roman_sim.frontend.frame_objects import FrameObjects
    from roman_sim.frontend.mask_noise import neighbour_pairs
    from roman_sim.mapping.mask_filter import (
        MaskFilterConfig,
        eroded_labels,
        masks_from_labels,
        masks_from_labels_reference,
    )

    _, _, frames = demo_frames
    for f in frames[::12]:
        ids = np.asarray(f.truth.object_ids)
        labels = (ids + 1).astype(np.int32)
        for px in (0, 4, 8, 12):
            cfg = MaskFilterConfig(erosion_px=px)
            fast, ref = masks_from_labels(labels, cfg), masks_from_labels_reference(labels, cfg)
            assert [m.bbox for m in fast] == [m.bbox for m in ref] and len(fast) > 0
            for a, b in zip(fast, ref):
                np.testing.assert_array_equal(a.pixels, b.pixels)
            r = cfg.erosion_radius(labels.shape[1])
            big = np.where(labels > 0, labels + 70000, 0)  # beyond 16 bits: the offset-by-offset path
            small = eroded_labels(labels, r)
            np.testing.assert_array_equal(eroded_labels(big, r), np.where(small > 0, small + 70000, 0))
        table = FrameObjects.of(ids, np.asarray(f.depth))
        wide = table.neighbour_pairs(5)
        assert table.neighbour_pairs(0) == neighbour_pairs(ids, 0) and wide == neighbour_pairs(ids, 5)
