"""``roman-sim report RUN --score NAME``: a plug-in's own score, ROMAN's on a tiny run, an unknown score."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from roman_sim.align import build_aligner
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.geometry import pose_4dof
from roman_sim.evaluation.metrics import score_pair
from roman_sim.evaluation.pairs import pair_truth
from roman_sim.evaluation.records import read_alignments
from roman_sim.evaluation.results import read_pairs_csv, write_pairs_csv
from roman_sim.evaluation.score_curves import score_curve, score_summaries
from roman_sim.mapping.io import load_submaps
from roman_sim.report.recompute import run_score_summaries

#: A user's aligner that gives its own score: ROMAN's estimate, scored by the fraction of the associated
#: centres that land within 0.2 m of their partner under it (1 - that fraction on odd pairs, so it is
#: not ROMAN's count under another name).
PLUGIN = """\
import numpy as np
from roman_sim.align import build_aligner


class Confident:
    name = "confident"

    def __init__(self):
        self.roman = build_aligner("roman", {})

    def align(self, a, b):
        out = self.roman.align(a, b)
        out.method = self.name
        if out.T_a_b is None:
            out.confidence = {}
            return out
        sel = out.associations
        moved = b.centers[sel[:, 1]] @ out.T_a_b[:3, :3].T + out.T_a_b[:3, 3]
        close = float(np.mean(np.linalg.norm(moved - a.centers[sel[:, 0]], axis=1) <= 0.2))
        out.confidence = {"closeness": close if (a.index + b.index) % 2 == 0 else 1.0 - close}
        return out
"""


@pytest.fixture(scope="module")
def plugin_folder(tmp_path_factory: pytest.TempPathFactory):
    """A run-like folder with only ``pairs.csv``: the plug-in ``confpkg.align:Confident`` and RANSAC on 6 pairs."""
    home = tmp_path_factory.mktemp("plugin")
    (home / "confpkg").mkdir()
    (home / "confpkg" / "__init__.py").write_text("")
    (home / "confpkg" / "align.py").write_text(PLUGIN)
    sys.path.insert(0, str(home))
    try:
        plugin = build_aligner("confpkg.align:Confident")
        ransac = build_aligner("ransac100k", {"iterations": 5000})
        scores = []
        for seed in range(6):
            T = pose_4dof(2.0, -1.0, 0.1, np.deg2rad(40.0 * seed))
            a, b, _ = make_submap_pair(seed, 8, 4 + seed, 4, T_a_b=T, noise_m=0.05 + 0.05 * seed, descriptor_dim=32)
            a, b = (
                type(a)(**{**a.__dict__, "index": seed}),
                type(b)(**{**b.__dict__, "robot": "b", "index": seed}),
            )
            t = pair_truth(a, b)
            scores.append(score_pair(t, plugin.align(a.public(), b.public())))
            scores.append(score_pair(t, ransac.align(a.public(), b.public())))
    finally:
        sys.path.remove(str(home))
        for name in ("confpkg.align", "confpkg"):
            sys.modules.pop(name, None)
    run = home / "run"
    run.mkdir()
    write_pairs_csv(run / "pairs.csv", scores)
    return run, scores


def test_a_plugin_score_is_used_when_chosen(plugin_folder, run_cli) -> None:
    run, scores = plugin_folder
    mine = [s for s in scores if s.method == "confident"]
    values = sorted({v for s in mine for k, v in s.named if k == "closeness"})
    assert values  # the plug-in scored its pairs
    curve = score_curve([s for s in read_pairs_csv(run / "pairs.csv") if s.method == "confident"], "closeness")
    assert curve.thresholds.tolist() == values  # the sweep runs over the plug-in's own values
    code, out, err = run_cli("report", str(run), "--score", "associations")
    assert code == 0 and "'associations'" in out and "confident" in out and "ransac100k" in out
    # RANSAC does not give the plug-in's score: the one line names the score, the method and what it offers
    code, out, err = run_cli("report", str(run), "--score", "closeness")
    assert code == 1 and out == ""
    assert err.strip() == (
        "error: score 'closeness': method ransac100k does not offer it (it offers: associations, inliers)"
    )
    only = run.parent / "only_plugin"
    only.mkdir(exist_ok=True)
    write_pairs_csv(only / "pairs.csv", mine)
    code, out, _ = run_cli("report", str(only), "--score", "closeness")
    summary = score_summaries(mine, "closeness")[0]
    assert run_score_summaries(only, "closeness") == [summary]  # no config.yaml: the default settings
    assert code == 0 and "'closeness'" in out and f"{summary.auc:.3f}" in out


def test_an_unknown_score_is_one_line_and_writes_nothing(plugin_folder, cli_fails) -> None:
    run, _ = plugin_folder
    before = sorted((p.name, p.read_bytes()) for p in run.iterdir())
    line = cli_fails("report", run, "--score", "nope", "--rewrite")
    assert line == "error: score 'nope': method confident does not offer it (it offers: associations, closeness)"
    assert sorted((p.name, p.read_bytes()) for p in run.iterdir()) == before


def test_on_a_tiny_run_the_scores_are_the_hand_formulas(smoke_run, run_cli) -> None:
    run = Path(smoke_run.run_dir)
    records, _ = read_alignments(run / "alignments.json")
    n_assoc = {(r.a, r.b, r.method): len(r.associations) for r in records}
    sizes = {s.name: len(s) for s in load_submaps(run / "submaps" / "a.npz") + load_submaps(run / "submaps" / "b.npz")}
    rows = read_pairs_csv(run / "pairs.csv")
    assert {s.method for s in rows} == {"roman", "clipper"}
    solved = 0
    for s in rows:
        n = n_assoc[(s.truth.a, s.truth.b, s.method)]
        assert s.score("associations") == n == s.n_assoc
        named = dict(s.named)
        if not named:  # an alignment that stopped before CLIPPER ran offers the count only
            assert s.reason is not None
            continue
        solved += 1
        mean = (sizes[s.truth.a] + sizes[s.truth.b]) / 2
        assert named["percent_associations"] == (n / mean if mean else 0.0)
        assert 0 <= named["margin"] <= named["objective"]
        assert ("semantic" in named) == (s.method == "roman" and n > 0)
    assert solved > len(rows) // 2
    code, out, _ = run_cli("report", str(run), "--score", "margin")
    assert code == 0 and "'margin'" in out and "roman" in out and "clipper" in out
