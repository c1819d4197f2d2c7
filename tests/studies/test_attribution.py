"""The attribution study's machinery on the tiny smoke scenario: runs, resume, table, kept raw pairs,
the independent scorer's re-derivation, and bad input."""

from __future__ import annotations

import csv
import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.errors import ConfigError
from roman_sim.studies import independent_scorer as S
from roman_sim.studies.attribution import (
    FIELDS,
    AttributionConfig,
    Cell,
    attribution_block,
    drop_bootstrap,
    newcombe,
    plan_runs,
    run_cells,
    table_rows,
    write_table,
)

pytestmark = pytest.mark.timeout(900)

#: Short runs of the smoke scenario (both roles: the machinery, not the figures, is tested here).
SHORT = ["robots.0.max_length_m=30", "robots.1.max_length_m=30"]


def _cli(*args: str) -> Any:
    return CliRunner().invoke(app, list(args), catch_exceptions=False)


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, str]:
    root = tmp_path_factory.mktemp("attribution")
    args = ["study", "attribution", "--out", str(root / "study"), "--same", "smoke", "--opposite", "smoke"]
    args += ["--mechanism", "segmenter_view", "--methods", "roman", *(x for s in SHORT for x in ("--set", s))]
    res = _cli(*args, "--results", str(root / "kept"))
    assert res.exit_code == 0, res.output
    return root / "study", root / "kept", res.output


def _table(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_the_study_runs_every_role_and_mechanism_and_tables_them(study: tuple[Path, Path, str]) -> None:
    out, _, printed = study
    runs = sorted(p.name for p in (out / "runs").iterdir())
    assert runs == ["opposite__none", "opposite__segmenter_view", "same__none", "same__segmenter_view"]
    rows = _table(out / "attribution.csv")
    assert [(r["mechanism"], r["method"]) for r in rows] == [("none", "roman"), ("segmenter_view", "roman")]
    assert list(rows[0]) == list(FIELDS)
    for r in rows:
        cell = run_cells(out / "runs" / f"same__{r['mechanism']}", [r["method"]])[r["method"]]
        assert (int(r["same_hits"]), int(r["same_relevant"])) == (cell.hits, cell.relevant)
    assert "same -> opposite drop" in printed and "segmenter_view" in printed


def test_a_second_call_resumes_and_reuses_every_run(study: tuple[Path, Path, str]) -> None:
    out, _, _ = study
    before = (out / "attribution.csv").read_bytes()
    args = ["study", "attribution", "--out", str(out), "--same", "smoke", "--opposite", "smoke"]
    res = _cli(*args, "--mechanism", "segmenter_view", "--methods", "roman", *(x for s in SHORT for x in ("--set", s)))
    assert res.exit_code == 0, res.output
    assert res.output.count(": reused") == 4
    assert (out / "attribution.csv").read_bytes() == before


def test_the_independent_scorer_rederives_the_table_from_the_kept_raw_pairs(study: tuple[Path, Path, str]) -> None:
    _, kept, _ = study
    assert not list(kept.glob("runs/*/maps"))  # only the small files and the raw pairs are kept
    table = _table(kept / "attribution.csv")
    derived = S.attribution_rows(kept)
    assert len(table) == len(derived)
    for t, d in zip(table, derived):
        for k in FIELDS:
            if d[k] is None:
                assert t[k] == "", k
            elif isinstance(d[k], str):
                assert t[k] == d[k]
            else:
                assert float(t[k]) == pytest.approx(float(d[k]), abs=1e-6), k  # type: ignore[arg-type]


def test_newcombe_interval_matches_the_published_example() -> None:
    """Newcombe (1998), Statistics in Medicine 17, example (a): 56/70 - 48/80 -> [0.0524, 0.3339]."""
    lo, hi = newcombe(56, 70, 48, 80, 0.95) or (math.nan, math.nan)
    assert (round(lo, 4), round(hi, 4)) == (0.0524, 0.3339)
    assert S.newcombe_interval(56, 70, 48, 80, 0.95) == pytest.approx([lo, hi])
    assert newcombe(1, 0, 1, 2, 0.95) is None


def test_unknown_mechanism_fails_with_one_line_and_exit_1(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["study", "attribution", "--out", str(tmp_path), "--mechanism", "shadows"])
    assert res.exit_code == 1
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: mechanisms: unknown mechanism 'shadows' (allowed: ")
    assert not (tmp_path / "runs").exists()


def test_the_plan_checks_every_mechanism_before_running() -> None:
    with pytest.raises(ConfigError, match="unknown mechanism 'shadows'"):
        plan_runs(AttributionConfig(mechanisms=["road_side", "shadows"]))
    split = plan_runs(AttributionConfig(mechanisms=["occlusion"]))
    assert [r.name for r in split] == ["same__none", "same__occlusion", "opposite__none", "opposite__occlusion"]
    assert all('mapping.complete=["occluded"]' in r.overrides for r in split if r.mechanism == "occlusion")
    runs = plan_runs(AttributionConfig(mechanisms=["road_side"]))
    assert [r.name for r in runs] == ["same__none", "same__road_side", "opposite__none", "opposite__road_side"]
    road = [r for r in runs if r.mechanism == "road_side"]
    assert all("robots.0.path.lateral_offset_m=[0.0, 0.0]" in r.overrides for r in road)


def test_seeds_make_worlds_the_unit_each_run_in_every_world() -> None:
    runs = plan_runs(AttributionConfig(mechanisms=["road_side"], seeds=[2, 0]))
    assert [r.name for r in runs] == [
        *(f"{role}__{m}__s2" for role in ("same", "opposite") for m in ("none", "road_side")),
        *(f"{role}__{m}__s0" for role in ("same", "opposite") for m in ("none", "road_side")),
    ]
    assert all(r.seed == int(r.name[-1]) and f"seed={r.seed}" in r.overrides for r in runs)
    from roman_sim.pipeline.scenario import load_scenario

    assert load_scenario(runs[0].scenario, list(runs[0].overrides)).seed == 2


#: Two hand-made worlds that disagree: the drop is +0.8 in world 0 and -0.6 in world 1.
SAME, OPPOSITE = [(9, 10), (2, 10)], [(1, 10), (8, 10)]


def test_the_world_bootstrap_equals_a_hand_computation_and_is_wider_than_newcombe() -> None:
    # resamples (0, 0), (0, 1), (1, 1): drops 18/20 - 2/20 = 0.8, 11/20 - 9/20 = 0.1, 4/20 - 16/20 = -0.6;
    # the 2.5 % quantile lies 0.05 of the way from -0.6 to 0.1, the 97.5 % one 0.95 of the way from 0.1 to 0.8
    fixed = np.array([[0, 0], [0, 1], [1, 1]])
    lo, hi = drop_bootstrap(SAME, OPPOSITE, fixed, 0.95) or (math.nan, math.nan)
    assert (lo, hi) == pytest.approx((-0.6 + 0.05 * 0.7, 0.1 + 0.95 * 0.7))
    assert S.world_drop_interval(SAME, OPPOSITE, fixed.tolist(), 0.95) == pytest.approx([lo, hi])
    # through the table: pooled 11/20 - 9/20 = +0.1; 2000 seeded resamples reach both one-world extremes
    cfg = AttributionConfig(mechanisms=["road_side"], methods=["roman"], seeds=[0, 1])
    cells = {
        (role, mech, w): {"roman": Cell(k, n, 0)}
        for role, worlds in (("same", SAME), ("opposite", OPPOSITE))
        for mech in ("none", "road_side")
        for w, (k, n) in enumerate(worlds)
    }
    row = table_rows(cells, cfg)[0]
    assert (row.worlds, row.same_hits, row.same_relevant, row.opposite_hits) == (2, 11, 20, 9)
    assert row.drop == pytest.approx(0.1)
    assert (row.drop_lo, row.drop_hi) == pytest.approx(newcombe(11, 20, 9, 20, 0.95))
    assert (row.drop_worlds_lo, row.drop_worlds_hi) == pytest.approx((-0.6, 0.8))
    assert row.drop_worlds_hi - row.drop_worlds_lo > 2 * (row.drop_hi - row.drop_lo)
    picks = S.world_resamples(2, cfg.boot_draws, cfg.boot_seed)
    assert S.world_drop_interval(SAME, OPPOSITE, picks, 0.95) == pytest.approx([-0.6, 0.8])


def test_with_two_worlds_the_verdicts_use_the_world_bootstrap(tmp_path: Path) -> None:
    """The hand-made worlds: Newcombe's interval of the pooled drop excludes 0 at this size and the
    world bootstrap's includes it; the page's block says which interval it uses and follows it."""
    cfg = AttributionConfig(mechanisms=["descriptor_view"], methods=["roman"], seeds=[0, 1])
    big = {"same": [(90, 100), (60, 100)], "opposite": [(10, 100), (70, 100)]}  # drops +0.8 and -0.1
    cells = {
        (role, mech, w): {"roman": Cell(k, n, 0)}
        for role, worlds in big.items()
        for mech in ("none", "descriptor_view")
        for w, (k, n) in enumerate(worlds)
    }
    rows = table_rows(cells, cfg)
    assert rows[0].drop_lo > 0 and rows[0].drop_worlds_lo < 0
    write_table(rows, tmp_path)
    block = attribution_block(tmp_path)
    assert "Counts pooled over 2 worlds" in block and "use the world-bootstrap intervals" in block
    lo, hi = rows[0].drop_worlds_lo, rows[0].drop_worlds_hi
    assert f"- roman: all-on drop +0.35 (its world-bootstrap interval [{lo:+.2f}, {hi:+.2f}] includes 0)." in block
    assert "With `descriptor_view` off the drop is +0.35 (its world-bootstrap interval" in block


def test_one_world_has_no_world_bootstrap() -> None:
    cfg = AttributionConfig(mechanisms=["road_side"], methods=["roman"])
    roles, mechs = ("same", "opposite"), ("none", "road_side")
    cells = {(role, mech, None): {"roman": Cell(5, 10, 1)} for role in roles for mech in mechs}
    row = table_rows(cells, cfg)[0]
    assert row.worlds == 1 and row.drop_worlds_lo is None and row.drop_worlds_hi is None


@pytest.mark.parametrize(
    ("seeds", "message"),
    [
        ("", "error: seeds: empty (allowed: one or more world seeds >= 0, e.g. 0,1,2,3)"),
        ("0,-1", "error: seeds: -1 is negative (allowed: world seeds >= 0)"),
        ("1,2,1", "error: seeds: 1 named twice (each world seed once)"),
        ("0,one", "error: seeds: 'one' is not a whole number (allowed: world seeds >= 0, e.g. 0,1,2,3)"),
    ],
)
def test_bad_seeds_fail_with_one_line_naming_the_field(tmp_path: Path, seeds: str, message: str) -> None:
    res = CliRunner().invoke(app, ["study", "attribution", "--out", str(tmp_path / "s"), "--seeds", seeds])
    assert res.exit_code == 1
    assert res.output.strip().splitlines() == [message]
    assert not (tmp_path / "s").exists()


def test_the_config_refuses_bad_seeds_too() -> None:
    from roman_sim.core.config import validate_model

    with pytest.raises(ConfigError, match=r"seeds.*named twice"):
        validate_model(AttributionConfig, {"seeds": [3, 3]}, source="study attribution")


def test_the_independent_scorer_pools_worlds_and_bootstraps_them_as_the_study(
    study: tuple[Path, Path, str], tmp_path: Path
) -> None:
    """Two "worlds" made of the kept smoke runs (world 1's all-on runs are the switched-off ones):
    the study's pooled table and the scorer's, from the raw pairs alone, agree field by field."""
    out, kept, _ = study
    spec = json.loads((kept / "attribution.json").read_text())
    cfg = AttributionConfig.model_validate({**spec["config"], "seeds": [0, 1]})
    runs = []
    for seed in (0, 1):
        for r in spec["runs"]:
            src = r["run"] if seed == 0 else f"{r['role']}__{'segmenter_view' if r['mechanism'] == 'none' else 'none'}"
            name = f"{r['role']}__{r['mechanism']}__s{seed}"
            shutil.copytree(kept / "runs" / src, tmp_path / "runs" / name)
            runs.append({**r, "run": name, "seed": seed, "source": src})
    (tmp_path / "attribution.json").write_text(json.dumps({"config": cfg.model_dump(mode="json"), "runs": runs}))
    cells = {(r["role"], r["mechanism"], r["seed"]): run_cells(out / "runs" / r["source"], cfg.methods) for r in runs}
    table, derived = table_rows(cells, cfg), S.attribution_rows(tmp_path)
    assert len(table) == len(derived) == 2
    for t, d in zip(table, derived):
        assert t.worlds == d["worlds"] == 2
        for k in FIELDS:
            if d[k] is None or isinstance(d[k], str):
                assert getattr(t, k) == d[k], k
            else:
                assert getattr(t, k) == pytest.approx(d[k], abs=1e-12), k
