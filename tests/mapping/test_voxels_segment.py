"""Voxel set helpers and per-segment features against hand-computed values."""

from collections import Counter

import numpy as np
import pytest

from roman_sim.core.errors import MappingError
from roman_sim.mapping.segment import Segment, largest_cluster, obb_extents
from roman_sim.mapping.voxels import downsample, iou, iou_matrix, voxel_set


def test_voxel_iou_hand_computed():
    a = voxel_set(np.array([[0.05, 0.05, 0.05], [0.25, 0.05, 0.05], [0.45, 0.05, 0.05]]), 0.2)
    b = voxel_set(np.array([[0.25, 0.05, 0.05], [0.45, 0.05, 0.05], [0.65, 0.05, 0.05], [0.85, 0.0, 0.0]]), 0.2)
    assert len(a) == 3 and len(b) == 4
    assert iou(a, b) == pytest.approx(2 / 5)
    M = iou_matrix([a, b], [b, a, np.zeros(0, dtype=np.int64)])
    np.testing.assert_allclose(M, [[0.4, 1.0, 0.0], [1.0, 0.4, 0.0]])


def test_negative_coordinates_hash_distinctly():
    pts = np.array([[-0.1, 0, 0], [0.1, 0, 0], [0, -0.1, 0], [0, 0, -0.1]])
    assert len(voxel_set(pts, 0.2)) == 4


def test_downsample_means_per_voxel():
    pts = np.array([[0.01, 0.01, 0.01], [0.03, 0.03, 0.03], [1.01, 0.0, 0.0]])
    out = downsample(pts, 0.05)
    assert len(out) == 2
    assert any(np.allclose(p, [0.02, 0.02, 0.02]) for p in out)


def test_nonfinite_points_raise():
    with pytest.raises(MappingError):
        voxel_set(np.array([[np.nan, 0, 0]]), 0.1)


def _grid(nx, ny, nz, step=0.05):
    g = np.stack(np.meshgrid(*(np.arange(n) * step for n in (nx, ny, nz)), indexing="ij"), -1)
    return g.reshape(-1, 3)


@pytest.mark.parametrize(
    "pts, dominant",
    [
        (_grid(60, 1, 1), 0),  # line -> linearity
        (_grid(30, 30, 1), 1),  # plane -> planarity
        (np.random.default_rng(0).standard_normal((500, 3)), 2),  # blob -> scattering
    ],
)
def test_pca_features_of_lines_planes_blobs(pts, dominant):
    seg = Segment(0, pts, 0.0, 0.0)
    feats = seg.shape
    assert int(np.argmax(feats)) == dominant
    assert feats[dominant] > 0.8


def test_obb_volume_of_box_and_few_points():
    rng = np.random.default_rng(1)
    box = rng.uniform([0, 0, 0], [2.0, 1.0, 0.5], size=(2000, 3))
    ext, vol = obb_extents(box)
    np.testing.assert_allclose(ext, [2.0, 1.0, 0.5], atol=0.05)
    assert vol == pytest.approx(1.0, rel=0.1)
    assert obb_extents(box[:4])[1] == 0.0


def test_largest_cluster_keeps_big_blob():
    a = _grid(5, 5, 5)
    b = _grid(2, 2, 2) + 3.0
    kept = largest_cluster(np.vstack([a, b]), 0.25)
    assert len(kept) == len(a)


def test_running_mean_descriptor_and_purity():
    seg = Segment(3, np.zeros((0, 3)), 1.0, 1.0, 0)
    e1, e2 = np.eye(4)[0], np.eye(4)[1]
    seg.add_observation(_grid(3, 3, 3), 1.0, e1, Counter({5: 30}), 0.05)
    seg.add_observation(_grid(3, 3, 3), 2.0, e1, Counter({5: 50, 7: 20}), 0.05)
    seg.add_observation(_grid(3, 3, 3), 3.0, e2, Counter(), 0.05)
    d = seg.descriptor
    np.testing.assert_allclose(d, np.array([2, 1, 0, 0]) / np.sqrt(5), atol=1e-6)
    assert seg.num_sightings == 3 and seg.first_seen == 1.0 and seg.last_seen == 3.0
    assert seg.majority_id == 5 and seg.purity == pytest.approx(80 / 100)
    assert len(seg.points) == 27
