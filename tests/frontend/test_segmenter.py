"""Simulated segmenter: area filter, erosion, presets and each error model."""

import numpy as np
import pytest
from mapping_synth import INTR, T_BODY_CAM
from scipy import ndimage

from roman_sim.core.errors import ConfigError, MappingError
from roman_sim.core.sensors import Frame, FrameTruth
from roman_sim.frontend.segmenter import SEGMENTERS, SegmenterConfig, simulated_segmenter
from roman_sim.mapping.mask import Mask, ellipse_kernel
from roman_sim.mapping.protocols import Segmenter


def _frame(ids, depth=None, index=0):
    depth = np.full(ids.shape, 3.0, np.float32) if depth is None else depth
    return Frame("a", index, 0.0, None, depth, np.eye(4), T_BODY_CAM, INTR, FrameTruth(ids.astype(np.int32), np.eye(4)))


def _ids_boxes():
    ids = np.full((120, 160), -1)
    ids[10:50, 10:60] = 0  # 2000 px: inside [19200/900, 19200/9] = [21.3, 2133]
    ids[70:74, 100:104] = 1  # 16 px: below the area filter
    ids[60:110, 20:60] = 2  # 2000 px, not touching 0
    return ids


def test_perfect_preset_is_eroded_truth_after_area_filter():
    masks = simulated_segmenter("perfect").segment(_frame(_ids_boxes()))
    assert [m.object_ids for m in masks] == [(0,), (2,)]
    # Erosion 3 px at 640 px width is 1 px on these 160 px frames.
    truth = ndimage.binary_erosion(_ids_boxes() == 0, structure=ellipse_kernel(1), border_value=0)
    np.testing.assert_array_equal(masks[0].pixels, truth)
    assert masks[0].area == (40 - 2) * (50 - 2)


def test_area_filter_drops_huge_masks():
    ids = np.full((120, 160), -1)
    ids[:, :100] = 0  # 12000 px > A/9
    assert simulated_segmenter("perfect").segment(_frame(ids)) == []


def test_presets_and_protocol():
    assert {"perfect", "fastsam"} <= set(SEGMENTERS.names())
    assert isinstance(simulated_segmenter("fastsam", 1), Segmenter)
    with pytest.raises(ConfigError, match="valid: fastsam, perfect"):
        simulated_segmenter("sam9")
    with pytest.raises(MappingError):
        simulated_segmenter(SegmenterConfig(min_area_div=3.0, max_area_div=5.0))


def test_bad_shapes_raise():
    f = _frame(_ids_boxes())
    f.depth = np.zeros((10, 10), np.float32)
    with pytest.raises(MappingError, match="object_ids"):
        simulated_segmenter("perfect").segment(f)


def test_same_seed_same_masks_and_seed_matters():
    f = _frame(_ids_boxes(), index=3)
    a = simulated_segmenter("fastsam", 5).segment(f)
    b = simulated_segmenter("fastsam", 5).segment(f)
    assert len(a) == len(b) and all(np.array_equal(x.pixels, y.pixels) for x, y in zip(a, b))
    outs = {tuple(m.area for m in simulated_segmenter("fastsam", s).segment(f)) for s in range(6)}
    assert len(outs) > 1


def _only(**kw):
    base = SEGMENTERS.get("perfect").model_dump()
    base.update(kw)
    return simulated_segmenter(SegmenterConfig(**base), seed=0)


def test_missed_detections_likelier_for_small_and_far():
    ids = np.full((120, 160), -1)
    ids[10:50, 10:50] = 0  # large, near
    ids[90:100, 100:110] = 1  # small (100 px), near
    ids[10:50, 90:130] = 2  # large, far
    depth = np.full(ids.shape, 2.0, np.float32)
    depth[ids == 2] = 7.4
    seg = _only(miss_prob=0.02, miss_small_prob=0.6, miss_far_prob=0.6, erosion_px=0)
    seen = np.zeros(3)
    for i in range(150):
        for m in seg.segment(_frame(ids, depth, index=i)):
            seen[m.object_ids[0]] += 1
    assert seen[0] > 130 and seen[1] < 110 and seen[2] < 110


def test_oversegmentation_splits_large_objects():
    ids = np.full((120, 160), -1)
    ids[10:50, 10:60] = 0
    masks = _only(oversegment_prob=1.0, erosion_px=0).segment(_frame(ids))
    assert len(masks) == 2 and all(m.object_ids == (0,) for m in masks)
    assert masks[0].area + masks[1].area == 40 * 50
    assert not np.any(masks[0].pixels & masks[1].pixels)


def test_undersegmentation_follows_image_gap_and_depth_gap():
    ids = np.full((120, 160), -1)
    ids[10:40, 10:40] = 0
    ids[10:40, 40:70] = 1  # touches 0
    ids[70:100, 100:130] = 2  # far from both in the image
    depth = np.full(ids.shape, 3.0, np.float32)
    depth[:, 39:41] = 0.0  # the sensor invalidates depth across the shared edge: merges must not need it
    masks = _only(undersegment_prob=1.0, erosion_px=0).segment(_frame(ids, depth))
    assert sorted(m.object_ids for m in masks) == [(0, 1), (2,)]
    # The probability falls with the depth gap: exp(-3 / 1.5) at a 3 m gap.
    depth[ids == 1] = 6.0
    seg = _only(undersegment_prob=1.0, erosion_px=0, merge_depth_m=1.5)
    ((a, b, p),) = seg.merge_candidates(_frame(ids, depth))
    assert (a, b) == (0, 1) and p == pytest.approx(np.exp(-2.0))
    merged = sum(len(seg.segment(_frame(ids, depth, index=i))) == 2 for i in range(400))
    assert abs(merged - 400 * np.exp(-2.0)) <= 3 * np.sqrt(400 * np.exp(-2.0) * (1 - np.exp(-2.0)))
    # ... and with the image gap: 1 px apart at 160 px width is 4 px at 640, exp(-4 / 2).
    ids[10:40, 40] = -1
    depth[:] = 3.0
    ((_, _, p),) = _only(undersegment_prob=0.5).merge_candidates(_frame(ids, depth))
    assert p == pytest.approx(0.5 * np.exp(-2.0))
    ids[10:40, 40:43] = -1  # 3 px (12 px at 640): beyond three e-folds, never looked at
    assert _only(undersegment_prob=1.0).merge_candidates(_frame(ids, depth)) == []


def test_spurious_masks_lie_on_terrain():
    ids = _ids_boxes()
    masks = _only(spurious_rate=5.0, erosion_px=0).segment(_frame(ids))
    spurious = [m for m in masks if m.object_ids == ()]
    assert spurious
    assert all(np.all(ids[m.pixels] == -1) for m in spurious)


def test_noisy_boundaries_change_only_the_border():
    ids = np.full((120, 160), -1)
    ids[20:60, 20:60] = 0
    m = _only(boundary_noise_px=8, erosion_px=0).segment(_frame(ids))[0]  # 8 px at 640: 2 px here
    truth = ids == 0
    diff = m.pixels ^ truth
    assert diff.any()
    sq = np.ones((5, 5), bool)  # within 2 px (chessboard distance) of the boundary
    band = ndimage.binary_dilation(truth, sq) & ~ndimage.binary_erosion(truth, sq, border_value=1)
    assert not np.any(diff & ~band)


def test_mask_bbox():
    p = np.zeros((10, 10), bool)
    p[2:4, 5:9] = True
    assert Mask(p).bbox == (2, 4, 5, 9) and Mask(p).area == 8


def test_empty_image_gives_no_masks():
    f = _frame(np.zeros((0, 0), np.int32), np.zeros((0, 0), np.float32))
    assert simulated_segmenter("fastsam").segment(f) == []


def _turning_frame(ids, yaw, index):
    """``ids`` seen by a camera turned by ``yaw`` about the vertical (the object's bearing turns with it)."""
    f = _frame(ids, index=index)
    c, s = np.cos(yaw), np.sin(yaw)
    f.truth.T_world_body = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    return f


def test_view_dependent_splits_and_partial_masks():
    ids = np.full((120, 160), -1)
    ids[10:70, 50:75] = 5  # 1500 px: large enough to split (> 3 % of the image), within the area window
    seg = _only(view_split_frac=0.25, erosion_px=0)
    yaws = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    counts = np.array([len(seg.segment(_turning_frame(ids, y, k))) for k, y in enumerate(yaws)])
    assert set(counts) == {1, 2} and abs(np.mean(counts == 2) - 0.25) <= 1 / 360
    # The same bearing gives the same masks, whatever the frame and the robot.
    again = [len(seg.segment(_turning_frame(ids, y, 1000 + k))) for k, y in enumerate(yaws[:60])]
    assert again == counts[:60].tolist()
    # The split sector is one arc: two masks in one run of bearings (on the circle).
    two = counts == 2
    assert int(np.sum(two != np.roll(two, 1))) == 2
    part = _only(partial_frac=0.5, erosion_px=0)
    areas = np.array([sum(m.area for m in part.segment(_turning_frame(ids, y, k))) for k, y in enumerate(yaws)])
    keep = part.traits(5).keep
    assert abs(np.mean(areas < 1500) - 0.5) <= 1 / 360
    assert np.all(np.abs(areas[areas < 1500] / 1500 - keep) <= 1 / 60 + 1e-9)  # one image row of 25 px


def test_pixel_sizes_follow_the_image_width():
    """The same scene at 160 x 120 and 640 x 480: masks eroded by 1 px and by 3 px."""
    from roman_sim.mapping.mask_filter import MaskFilterConfig, masks_from_labels

    small = np.full((120, 160), -1)
    small[10:50, 10:60] = 0
    big = np.kron(small, np.ones((4, 4), int))
    for ids, radius in ((small, 1), (big, 3)):
        truth = ndimage.binary_erosion(ids == 0, structure=ellipse_kernel(radius), border_value=0)
        m = simulated_segmenter("perfect").segment(_frame(ids))[0]
        np.testing.assert_array_equal(m.pixels, truth)
        (f,) = masks_from_labels((ids + 1).astype(np.int32), MaskFilterConfig())
        np.testing.assert_array_equal(f.pixels, truth)
    assert MaskFilterConfig().erosion_radius(320) == 2  # 1.5 rounds up
