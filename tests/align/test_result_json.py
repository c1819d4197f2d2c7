"""``AlignResult`` to JSON and back: exact floats, integer associations, numpy extras made plain."""

from __future__ import annotations

import numpy as np

from roman_sim.align.base import AlignResult, ResultRow
from roman_sim.core.records import dumps_record, loads_record


def _again(res: AlignResult) -> AlignResult:
    """``res`` as the row a chunk checkpoint or an aligner's record holds, written and read back."""
    row = loads_record(dumps_record(res.row("a/0", "b/1")), ResultRow, "row")
    assert (row.a, row.b) == ("a/0", "b/1")
    return AlignResult.from_row(row)


def test_a_result_survives_json_bit_for_bit() -> None:
    rng = np.random.default_rng(3)
    T = np.eye(4)
    T[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    T[:3, 3] = rng.normal(size=3) * 1e3
    res = AlignResult(
        "roman",
        T,
        np.array([[0, 4], [2, 7]], dtype=np.int32),
        np.array([0.1, 1 / 3]),
        0.012345678901234,
        None,
        {"putative": np.int64(17), "ratio": np.float32(0.5), "hist": np.arange(3), "pair": (1, "a"), "kind": object},
    )
    back = _again(res)
    assert back.method == "roman" and back.reason is None and back.runtime_s == res.runtime_s
    assert back.T_a_b is not None and back.T_a_b.tobytes() == T.tobytes()
    assert back.associations.dtype == np.int64 and back.associations.tolist() == [[0, 4], [2, 7]]
    assert back.scores.tobytes() == res.scores.tobytes()
    assert back.info == {"putative": 17, "ratio": 0.5, "hist": [0, 1, 2], "pair": [1, "a"], "kind": str(object)}


def test_a_failure_keeps_its_reason_and_empty_shapes() -> None:
    res = AlignResult.failure("ransac", "too few associations", runtime_s=0.5, putative=2)
    back = _again(res)
    assert back.T_a_b is None and back.reason == "too few associations" and back.info == {"putative": 2}
    assert back.associations.shape == (0, 2) and back.scores.shape == (0,)
