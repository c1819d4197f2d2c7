"""A loop closure in a solved variant's row and back: exact transform, optional noise overrides kept as None."""

from __future__ import annotations

import numpy as np

from roman_sim.core.records import dumps_record, loads_record
from roman_sim.evaluation.variants import ClosureRow
from roman_sim.posegraph import LoopClosure


def test_a_closure_survives_json_bit_for_bit() -> None:
    T = np.eye(4)
    T[:3, 3] = [1 / 3, -2e5, 0.1]
    for sigma in ((None, None), (0.25, 7.0)):
        c = LoopClosure("a", np.int64(3), "b", 12, T, np.int32(9), *sigma, source="roman")
        row = loads_record(dumps_record(ClosureRow.of(c, 0.5)), ClosureRow, "closure")
        back = row.closure()
        assert (back.robot_a, back.submap_a, back.robot_b, back.submap_b, row.weight) == ("a", 3, "b", 12, 0.5)
        assert back.T_a_b.tobytes() == T.tobytes() and back.n_associations == 9
        assert (back.sigma_m, back.sigma_deg, back.source) == (*sigma, "roman")
        assert type(back.submap_a) is int and type(back.n_associations) is int
