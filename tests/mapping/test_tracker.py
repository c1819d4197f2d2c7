"""Tracker on hand-made observations: association, lifecycle, merging and removal filters."""

from collections import Counter

import numpy as np

from roman_sim.mapping.segment import Segment, Status
from roman_sim.mapping.tracker import MappingConfig, Observation, Tracker


def _box(lo, hi, step=0.05):
    axes = [np.arange(a, b, step) for a, b in zip(lo, hi)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def _obs(pts, t, oid=0):
    return Observation(pts, t, None, Counter({oid: len(pts)}))


HERE = np.zeros(3)


def test_association_lifecycle_and_finish_by_time():
    tr = Tracker(MappingConfig())
    a, b = _box([0, 0, 0], [0.6, 0.6, 0.6]), _box([3, 0, 0], [3.6, 0.6, 0.6])
    tr.update([_obs(a, 0.0, 0), _obs(b, 0.0, 1)], 0.0, HERE)
    assert [s.status for s in tr.live] == [Status.NURSERY] * 2
    # second sighting of a (shifted 0.1 m: IoU still high); b unseen
    tr.update([_obs(a + 0.1, 0.2, 0)], 0.2, HERE)
    assert tr.live[0].status is Status.ACTIVE and tr.live[0].num_sightings == 2
    tr.update([], 0.5, HERE)  # b: nursery unseen > 0.4 s -> deleted
    assert [s.id for s in tr.live] == [0]
    tr.update([], 0.7, HERE)  # a: active unseen > 0.4 s -> inactive
    assert tr.live[0].status is Status.INACTIVE
    tr.update([], 15.1, HERE)
    assert tr.live[0].status is Status.INACTIVE
    tr.update([], 15.3, HERE)  # unseen > 15 s -> finished
    assert tr.live == [] and [s.id for s in tr.finished] == [0]


def test_finish_by_distance_and_new_segment_below_min_iou():
    tr = Tracker(MappingConfig())
    a = _box([0, 0, 0], [0.6, 0.6, 0.6])
    tr.update([_obs(a, 0.0)], 0.0, HERE)
    tr.update([_obs(a + [0.8, 0, 0], 0.1)], 0.1, HERE)  # IoU 0 -> a new segment
    assert len(tr.live) == 2
    tr.update([_obs(a, 0.2)], 0.2, HERE)
    tr.update([], 0.7, HERE)
    tr.update([], 0.8, np.array([10.5, 0, 0]))  # > 10 m away -> finished
    assert [s.id for s in tr.finished] == [0]


def test_hungarian_assigns_each_observation_to_its_best_segment():
    tr = Tracker(MappingConfig())
    a, b = _box([0, 0, 0], [1.0, 0.6, 0.6]), _box([1.0, 0, 0], [2.0, 0.6, 0.6])
    tr.update([_obs(a, 0.0, 0), _obs(b, 0.0, 1)], 0.0, HERE)
    tr.update([_obs(b + [0.05, 0, 0], 0.1, 1), _obs(a + [0.05, 0, 0], 0.1, 0)], 0.1, HERE)
    assert len(tr.live) == 2
    assert {s.id: s.majority_id for s in tr.live} == {0: 0, 1: 1}
    assert all(s.purity == 1.0 for s in tr.live)


def test_overlapping_segments_merge_keeping_the_older_id():
    tr = Tracker(MappingConfig())
    left, right = _box([0, 0, 0], [0.5, 1, 1]), _box([0.5, 0, 0], [1.0, 1, 1])
    tr.update([_obs(left, 0.0), _obs(right, 0.0)], 0.0, HERE)
    tr.update([_obs(np.vstack([left, right]), 0.1)], 0.1, HERE)
    assert [s.id for s in tr.live] == [0]
    assert tr.live[0].status is Status.ACTIVE


def test_removal_filters():
    tr = Tracker(MappingConfig())
    keep = Segment(0, _box([0, 0, 0], [0.5, 0.5, 1.0]), 0, 0)
    speck = Segment(1, _box([0, 0, 0], [0.2, 0.2, 0.2]), 0, 0)
    wall = Segment(2, _box([0, 0, 0], [4.0, 0.1, 3.5], step=0.1), 0, 0)
    few = Segment(3, _box([0, 0, 0], [1.0, 0.05, 0.05], step=0.4), 0, 0)
    assert [tr.keep(s) for s in (keep, speck, wall, few)] == [True, False, False, False]


def test_flush_drops_nursery_and_keeps_largest_cluster():
    tr = Tracker(MappingConfig())
    a = _box([0, 0, 0], [0.6, 0.6, 0.6])
    stray = np.array([[3.0, 3.0, 3.0]])
    tr.update([_obs(np.vstack([a, stray]), 0.0)], 0.0, HERE)
    tr.update([_obs(a, 0.1)], 0.1, HERE)
    tr.update([_obs(a + 5.0, 0.1)], 0.1, HERE)  # a nursery segment
    out = tr.flush()
    assert [s.id for s in out] == [0]
    assert len(out[0].points) == len(a)


def test_mapping_config_is_strict():
    import pytest

    from roman_sim.core.config import validate_model
    from roman_sim.core.errors import ConfigError

    with pytest.raises(ConfigError, match="max_depth"):
        validate_model(MappingConfig, {"max_depth_m": -1})
    with pytest.raises(ConfigError, match="unknown key"):
        validate_model(MappingConfig, {"voxel_size": 0.1})
    assert MappingConfig().iou_voxel == 0.2 and MappingConfig().min_iou == 0.25
