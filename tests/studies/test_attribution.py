"""The attribution study's machinery on the tiny smoke scenario: runs, resume, table, kept raw pairs,
the independent scorer's re-derivation, and bad input."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from roman_sim.cli import app
from roman_sim.core.errors import ConfigError
from roman_sim.studies import independent_scorer as S
from roman_sim.studies.attribution import FIELDS, AttributionConfig, newcombe, plan_runs, run_cells

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
    with pytest.raises(ConfigError, match="occlusion cannot be switched off"):
        plan_runs(AttributionConfig(mechanisms=["road_side", "occlusion"]))
    runs = plan_runs(AttributionConfig(mechanisms=["road_side"]))
    assert [r.name for r in runs] == ["same__none", "same__road_side", "opposite__none", "opposite__road_side"]
    road = [r for r in runs if r.mechanism == "road_side"]
    assert all("robots.0.path.lateral_offset_m=[0.0, 0.0]" in r.overrides for r in road)
