"""Hamming distances, bit majorities and the L1 BoW score against hand computations."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.align.visual import hamming as hm
from roman_sim.align.visual.bow import BowVector, l1_score, score_matrix


def _naive(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.unpackbits(a[:, None, :] ^ b[None, :, :], axis=-1).sum(axis=-1)


def test_hamming_matches_bit_count_and_both_popcounts_agree(monkeypatch) -> None:
    rng = np.random.default_rng(0)
    a, b = rng.integers(0, 256, (37, 32), dtype=np.uint8), rng.integers(0, 256, (11, 32), dtype=np.uint8)
    ref = _naive(a, b)
    np.testing.assert_array_equal(hm.hamming_matrix(a, b, block=5), ref)
    np.testing.assert_array_equal(hm.hamming(a[:, None, :], b[None]), ref)
    monkeypatch.setattr(hm, "_HAS_BITWISE_COUNT", False)
    np.testing.assert_array_equal(hm.hamming_matrix(a, b), ref)
    assert hm.hamming(a[:1], a[:1])[0] == 0
    assert hm.hamming(np.zeros((1, 32), np.uint8), np.full((1, 32), 255, np.uint8))[0] == 256


def test_majority_sets_a_bit_when_at_least_half_set_it() -> None:
    d = np.zeros((4, 32), np.uint8)
    d[0, 0] = 0b1111_0000
    d[1, 0] = 0b1100_0000
    d[2, 0] = 0b1000_0000
    # bit 7: 3 of 4, bit 6: 2 of 4 (a tie: set), bits 5-4: 1 of 4
    assert hm.majority(d)[0] == 0b1100_0000
    assert hm.majority(d[:3])[0] == 0b1100_0000  # bit 6: 2 of 3
    assert hm.majority(d[1:3])[0] == 0b1100_0000  # bit 6: 1 of 2 (tie: set)
    centres, nonempty = hm.majority_by_label(d, np.array([2, 2, 2, 0]), 3)
    np.testing.assert_array_equal(nonempty, [True, False, True])
    assert centres[2, 0] == 0b1100_0000 and centres[0, 0] == 0 and not centres[1].any()


def _vec(words, values) -> BowVector:
    v = np.asarray(values, np.float32)
    return BowVector(np.asarray(words, np.int32), v / v.sum())


def test_l1_score_is_dbow2_formula() -> None:
    v1, v2 = _vec([1, 4, 7], [2, 1, 1]), _vec([4, 7, 9, 12], [1, 1, 1, 1])
    dense = np.zeros((2, 13))
    dense[0, v1.words], dense[1, v2.words] = v1.values, v2.values
    expected = 1 - 0.5 * np.abs(dense[0] - dense[1]).sum()  # = min(.25,.25) + min(.25,.25) = 0.5
    assert l1_score(v1, v2) == pytest.approx(expected, abs=1e-6)
    assert expected == pytest.approx(0.5, abs=1e-6)
    assert l1_score(v1, v1) == pytest.approx(1.0, abs=1e-6)
    assert l1_score(v1, _vec([0, 2], [1, 1])) == 0.0
    assert l1_score(v1, BowVector.empty()) == 0.0
    S = score_matrix([v1, v2, BowVector.empty()], [v2, v1])
    np.testing.assert_allclose(S, [[0.5, 1.0], [1.0, 0.5], [0.0, 0.0]], atol=1e-6)
    assert score_matrix([], [v1]).shape == (0, 1)
