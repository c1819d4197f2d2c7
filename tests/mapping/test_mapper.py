"""Mapper on synthetic ray-cast frames: one segment per object, drift, merging, filters."""

import numpy as np
import pytest
from mapping_synth import SPHERES, drive, frame_at

from roman_sim.core.errors import MappingError
from roman_sim.core.geometry import pose_4dof, transform_points
from roman_sim.core.sensors import backproject
from roman_sim.frontend.segmenter import simulated_segmenter
from roman_sim.frontend.semantics import SimulatedEncoder
from roman_sim.mapping.mapper import Mapper
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.tracker import MappingConfig
from roman_sim.mapping.voxels import downsample


def _run(frames, segmenter=None, encoder=None):
    m = Mapper(MappingConfig(), segmenter or simulated_segmenter("perfect"), encoder)
    for f in frames:
        m.process(f)
    return m.finish()


def _visible_centres(frames, n):
    """True centre of the visible part of each object (world frame, depth <= 7.5 m)."""
    pts = {k: [] for k in range(n)}
    for f in frames:
        for k in range(n):
            sel = (f.truth.object_ids == k) & (f.depth <= 7.5)
            pts[k].append(
                transform_points(f.truth.T_world_body @ f.T_body_cam, backproject(f.depth, f.intrinsics, sel))
            )
    return {k: downsample(np.vstack(v), 0.05).mean(axis=0) for k, v in pts.items()}


def test_perfect_zero_drift_one_segment_per_object():
    frames = drive()
    smap = _run(frames)
    truth = _visible_centres(frames, len(SPHERES))
    assert sorted(s.majority_id for s in smap.segments) == [0, 1, 2]
    for s in smap.segments:
        assert s.purity == 1.0
        assert np.linalg.norm(s.center - truth[s.majority_id]) < 0.3
    assert len({s.id for s in smap.segments}) == 3
    assert smap.T_odom_body.shape == (12, 4, 4) and smap.times[-1] == pytest.approx(11 / 6)


def test_drifted_frame_moves_segments_by_the_drift():
    T_drift = pose_4dof(0.7, -0.4, 0.1, 0.08)
    plain = {s.majority_id: s.center for s in _run(drive()).segments}
    drifted = {s.majority_id: s.center for s in _run(drive(T_odom_world=T_drift)).segments}
    assert plain.keys() == drifted.keys() == {0, 1, 2}
    for k in plain:
        np.testing.assert_allclose(drifted[k], transform_points(T_drift, plain[k][None])[0], atol=0.03)


class SplittingSegmenter:
    """Perfect masks, but every object is split in two on every third frame."""

    reads_truth = True

    def __init__(self):
        self.inner = simulated_segmenter("perfect")

    def segment(self, frame):
        masks = self.inner.segment(frame)
        if frame.index % 3:
            return masks
        out = []
        for m in masks:
            r0, r1, c0, c1 = m.bbox
            left = m.pixels.copy()
            left[:, (c0 + c1) // 2 :] = False
            out += [Mask(left, m.object_ids), Mask(m.pixels & ~left, m.object_ids)]
        return out


def test_split_masks_merge_back():
    smap = _run(drive(n=15), SplittingSegmenter())
    assert sorted(s.majority_id for s in smap.segments) == [0, 1, 2]


class GroundSegmenter:
    """Perfect masks plus one mask of all near terrain pixels (a ground plane)."""

    reads_truth = True

    def __init__(self):
        self.inner = simulated_segmenter("perfect")

    def segment(self, frame):
        ground = (frame.truth.object_ids < 0) & (frame.depth > 0) & (frame.depth < 7.0)
        return self.inner.segment(frame) + [Mask(ground)]


def test_filters_drop_planes_and_specks():
    spheres = SPHERES + [(np.array([3.0, 0.8, 0.1]), 0.07)]  # a speck
    smap = _run(drive(spheres), GroundSegmenter())
    assert sorted(s.majority_id for s in smap.segments) == [0, 1, 2]


def test_empty_and_invalid_frames_are_skipped():
    frames = drive(n=3)
    for f in frames:
        f.depth = np.zeros_like(f.depth)
    m = Mapper(MappingConfig(), simulated_segmenter("perfect"))
    assert [m.process(f) for f in frames] == [0, 0, 0]
    assert len(m.finish()) == 0
    f = frame_at([], 0, 0, 0, 0.0, 0)
    m = Mapper(MappingConfig(), GroundSegmenter())
    f.depth = np.where(f.depth > 7.0, f.depth, 0).astype(np.float32)  # the mask has no valid depth
    assert m.process(f) == 0


def test_mapper_rejects_inconsistent_input():
    frames = drive(n=3)
    m = Mapper(MappingConfig(), simulated_segmenter("perfect"))
    m.process(frames[1])
    with pytest.raises(MappingError, match="back in time"):
        m.process(frames[0])
    other = frame_at(SPHERES, 0, 0, 0, 1.0, 2, robot="b")
    with pytest.raises(MappingError, match="robot"):
        m.process(other)
    bad = drive(n=3)[2]
    bad.T_odom_body = np.full((4, 4), np.nan)
    with pytest.raises(MappingError, match="T_odom_body"):
        m.process(bad)
    m.finish()
    with pytest.raises(MappingError, match="finish"):
        m.process(frames[2])


def test_same_seed_same_map_with_noisy_segmenter_and_descriptors():
    def run():
        enc = SimulatedEncoder(seed=4, families={0: "rock", 1: "conifer", 2: "rock"})
        return _run(drive(), simulated_segmenter("fastsam", 4), enc)

    a, b = run(), run()
    assert [s.id for s in a.segments] == [s.id for s in b.segments]
    for x, y in zip(a.segments, b.segments):
        np.testing.assert_array_equal(x.points, y.points)
        np.testing.assert_array_equal(x.descriptor, y.descriptor)
    assert all(s.descriptor is not None for s in a.segments)


def test_empty_image_is_a_clear_error():
    f = drive(n=1)[0]
    f.depth = np.zeros((0, 0), np.float32)
    f.truth.object_ids = np.zeros((0, 0), np.int32)
    with pytest.raises(MappingError, match="depth shape"):
        Mapper(MappingConfig(), simulated_segmenter("fastsam")).process(f)
