"""The trajectory variants: which pose graphs a run has, which closures each gets, and a closure's verdict."""

from __future__ import annotations

import numpy as np
import pytest

from roman_sim.core.errors import EvaluationError
from roman_sim.core.geometry import inv_T, pose_4dof
from roman_sim.core.records import RecordError, dumps_record, from_json, loads_record, to_json_object
from roman_sim.evaluation.atetable import TrajectoryVariant
from roman_sim.evaluation.metrics import closure_correct
from roman_sim.evaluation.pairs import PairTruth
from roman_sim.evaluation.types import AlignmentRecord
from roman_sim.evaluation.variants import (
    ORACLE_ASSOCIATIONS,
    VariantRow,
    graph_variants,
    odometry_variants,
    variant_of_row,
    variant_row,
)
from roman_sim.mapping.types import Submap, SubmapTruth

#: True submap poses in the world: robot a at x = 0 and 10, robot b at x = 1 (turned 180 deg) and 30.
POSES = {
    "a/0": pose_4dof(0, 0, 0, 0),
    "a/1": pose_4dof(10, 0, 0, 0),
    "b/0": pose_4dof(1, 0, 0, np.pi),
    "b/1": pose_4dof(30, 0, 0, 0),
}


def _submap(name: str, truth: bool = True) -> Submap:
    robot, index = name.split("/")
    z = np.zeros((0, 3))
    st = SubmapTruth(POSES[name], np.zeros(0, np.int64), np.zeros(0)) if truth else None
    return Submap(
        robot, int(index), 0.0, np.eye(4), np.zeros(0, np.int64), z, np.zeros(0), z, np.zeros((0, 4)), z, truth=st
    )


SUBMAPS = [_submap(n) for n in POSES]


def _true(a: str, b: str) -> np.ndarray:
    return inv_T(POSES[a]) @ POSES[b]


def _truth(a: str, b: str, relevant: bool) -> PairTruth:
    ra, ia = a.split("/")
    rb, ib = b.split("/")
    kind = "inter" if ra != rb else "intra"
    T = _true(a, b)
    return PairTruth(
        a, b, ra, rb, int(ia), int(ib), T, float(np.linalg.norm(T[:3, 3])), 0.0, 0.5, 0.0, relevant, kind, 1, 1
    )


TRUTHS = {(t.a, t.b): t for t in (_truth("a/0", "b/0", True), _truth("a/1", "b/1", False), _truth("a/1", "b/0", True))}
ALIGNMENTS = [
    AlignmentRecord("a/0", "b/0", "roman", 7, _true("a/0", "b/0")),
    AlignmentRecord("a/1", "b/1", "roman", 2, np.eye(4)),  # a false closure below the threshold
    AlignmentRecord("a/1", "b/0", "roman", 3, None),  # no transform: no closure
    AlignmentRecord("a/1", "b/0", "visual", 40, _true("a/1", "b/0")),
    AlignmentRecord("a/0", "b/0", "clipper", 9, np.eye(4)),
]


def _ends(v: TrajectoryVariant) -> list[tuple[str, int, str, int, int, str]]:
    return [(c.robot_a, c.submap_a, c.robot_b, c.submap_b, c.n_associations, c.source) for c in v.closures]


def test_without_a_visual_method_the_run_has_the_method_s_graph_and_the_oracle() -> None:
    graphs = graph_variants("roman", None, 4, SUBMAPS, ALIGNMENTS, TRUTHS)
    assert list(graphs) == ["roman", "oracle"]
    assert _ends(graphs["roman"]) == [("a", 0, "b", 0, 7, "roman"), ("a", 1, "b", 1, 2, "roman")]
    assert graphs["roman"].association_thresh is None and graphs["roman"].source == "roman"
    # the oracle: the true pose of every relevant pair, in pair-name order
    assert _ends(graphs["oracle"]) == [
        ("a", 0, "b", 0, ORACLE_ASSOCIATIONS, "oracle"),
        ("a", 1, "b", 0, ORACLE_ASSOCIATIONS, "oracle"),
    ]
    np.testing.assert_allclose(graphs["oracle"].closures[1].T_a_b, _true("a/1", "b/0"))
    assert graph_variants("visual", "visual", 4, SUBMAPS, ALIGNMENTS, TRUTHS).keys() == {"visual", "oracle"}


def test_with_a_visual_method_the_combined_graph_has_the_accepted_closures_and_the_visual_ones() -> None:
    graphs = graph_variants("roman", "visual", 4, SUBMAPS, ALIGNMENTS, TRUTHS)
    assert list(graphs) == ["roman", "visual", "combined", "oracle"]
    assert _ends(graphs["visual"]) == [("a", 1, "b", 0, 40, "visual")]
    assert _ends(graphs["combined"]) == [("a", 0, "b", 0, 7, "roman"), ("a", 1, "b", 0, 40, "visual")]
    assert graphs["visual"].association_thresh == 0 and graphs["combined"].association_thresh == 0
    assert [v.fit for v in graphs.values()] == ["joint"] * 4
    assert [(k, v.fit, v.source) for k, v in odometry_variants().items()] == [
        ("odometry", "joint", "odometry"),
        ("odometry_no_prior", "per_robot", "odometry"),
    ]


def test_a_closure_is_correct_within_the_tolerances_of_the_true_pose() -> None:
    subs = {s.name: s for s in SUBMAPS}
    graphs = graph_variants("roman", "clipper", 4, SUBMAPS, ALIGNMENTS, TRUTHS)
    right, wrong = graphs["roman"].closures[0], graphs["clipper"].closures[0]
    assert closure_correct(right, subs, 5.0, 1.0)
    assert not closure_correct(wrong, subs, 5.0, 1.0)  # identity for a pair turned 180 deg, 1 m apart
    assert closure_correct(wrong, subs, 180.0, 2.0)
    with pytest.raises(EvaluationError, match=r"closure a/0\|b/0 joins submaps without truth"):
        closure_correct(right, {**subs, "b/0": _submap("b/0", truth=False)}, 5.0, 1.0)


def test_a_solved_variant_round_trips_through_json() -> None:
    graph = graph_variants("roman", None, 4, SUBMAPS, ALIGNMENTS, TRUTHS)["roman"]
    solved = TrajectoryVariant(graph.description, graph.fit, graph.source, graph.closures, [0.98, None])
    name, back = variant_of_row(loads_record(dumps_record(variant_row("roman", solved)), VariantRow, "v"))
    assert name == "roman" and back.weights == [0.98, None] and _ends(back) == _ends(solved)
    assert back.closures[0].T_a_b.tobytes() == solved.closures[0].T_a_b.tobytes()  # bit for bit
    assert type(back.closures[0].submap_a) is int and back.closures[0].source == solved.closures[0].source
    bad = {**to_json_object(variant_row("roman", solved)), "fit": "both"}
    with pytest.raises(RecordError, match=r"^v: field fit: expected one of 'joint', 'per_robot', got a string"):
        from_json(VariantRow, bad, "v")
