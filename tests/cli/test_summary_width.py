"""The run summary reads in full at 80 columns: every figure of the committed demo, nothing cut."""

from __future__ import annotations

import pytest
from committed_results import REFERENCE

from roman_sim.cli.run import print_summary
from roman_sim.evaluation.atetable import read_ate
from roman_sim.evaluation.records import read_map_stats
from roman_sim.evaluation.results import read_metrics_json
from roman_sim.pipeline.result import RunResult
from roman_sim.pipeline.scenario import load_scenario

DEMO = REFERENCE / "demo"


@pytest.mark.skipif(not (DEMO / "metrics.json").is_file(), reason="no committed demo run")
@pytest.mark.parametrize("columns", [80, 200])
def test_the_demo_summary_fits_80_columns_with_every_figure(
    columns: int, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    metrics = read_metrics_json(DEMO / "metrics.json")
    run = RunResult(
        DEMO,
        load_scenario(DEMO / "config.yaml"),
        metrics,
        read_ate(DEMO / "ate.json")[0],
        read_map_stats(DEMO / "map_stats.json")[0],
    )
    monkeypatch.setenv("COLUMNS", str(columns))
    print_summary(run)
    out = capsys.readouterr().out
    assert "…" not in out and max(len(line) for line in out.splitlines()) <= columns
    flat = " ".join(out.split())
    lead = "Cross-robot pairs, 44 relevant. At max recall roman leads with 0.68 (30/44) [0.53, 0.80]"
    assert flat.index("pairs scored") < flat.index(lead) < flat.index("cross-robot (headline) pairs: recall")
    words = out.split()
    for kind in ("inter", "intra"):
        for m in metrics.methods:
            s = metrics.stats(m, None, kind)
            row = f"{s.max_hits}/{s.n_relevant}"
            cells = [b.stats for b in metrics.method(m).set(kind).heading_bins if b.stats.n_relevant]
            for want in [
                row,
                f"{s.hits_at_precision_1}/{s.n_relevant}",
                *[f"{c.max_hits}/{c.n_relevant}" for c in cells],
            ]:
                assert want in words, (m, kind, want)
    # one row per method in each of the two tables of each pair set, with its method name whole
    for m in metrics.methods:
        tables = out[out.index("(headline) pairs: recall") : out.index("ATE RMSE (m)")].splitlines()
        assert sum(1 for line in tables if line.split()[:1] == [m]) == 4
    assert "odometry               2/2     0.38            0.99" in out
