"""The report's opening paragraph states figures that follow from the demo's raw pairs.

The figures are recomputed here from ``pairs.csv.gz`` with the csv module and the Wilson
formula written out, not through the evaluation package; the ATE from ``ate.json``.
"""

from __future__ import annotations

import csv
import gzip
import io
import math
import re

import pytest
import yaml
from committed_results import REFERENCE

from roman_sim.evaluation.atetable import read_ate
from roman_sim.evaluation.results import read_metrics_json
from roman_sim.report.lead import lead_paragraph
from roman_sim.report.markdown import report_markdown

DEMO = REFERENCE / "demo"
pytestmark = pytest.mark.skipif(not (DEMO / "pairs.csv.gz").is_file(), reason="no committed demo run")
Z = 1.959963984540054  # the 97.5 % normal quantile


def _wilson(k: int, n: int) -> tuple[float, float]:
    p, d = k / n, 1 + Z * Z / n
    c, h = (p + Z * Z / (2 * n)) / d, Z * math.sqrt(p * (1 - p) / n + Z * Z / (4 * n * n)) / d
    return max(0.0, c - h), min(1.0, c + h)


def _by_hand() -> tuple[dict[str, dict[str, tuple[int, int]]], int]:
    """method -> point -> (hits, relevant) over the relevant cross-robot pairs; the acceptance k."""
    rows = list(csv.DictReader(io.StringIO(gzip.decompress((DEMO / "pairs.csv.gz").read_bytes()).decode())))
    acc = int(yaml.safe_load((DEMO / "config.yaml").read_text())["posegraph"]["lc_association_thresh"])
    out: dict[str, dict[str, tuple[int, int]]] = {}
    for m in sorted({r["method"] for r in rows}):
        mine = [r for r in rows if r["method"] == m and r["kind"] == "inter"]
        rel = sum(r["relevant"] == "true" for r in mine)

        def at(k: int, mine: list[dict[str, str]] = mine) -> tuple[int, int]:
            pos = [r for r in mine if int(r["n_assoc"]) >= k]
            tp = sum(r["correct"] == "true" and r["relevant"] == "true" for r in pos)
            return tp, sum(r["correct"] != "true" for r in pos)

        sweep = [at(k) for k in range(31)]
        p90 = next((tp for tp, fp in sweep if tp + fp and 10 * tp >= 9 * (tp + fp)), 0)
        out[m] = {"max recall": (max(tp for tp, _ in sweep), rel), "precision >= 0.9": (p90, rel)}
        out[m][f"acceptance (k = {acc})"] = (at(acc)[0], rel)
    return out, acc


def _cell(h: int, n: int) -> str:
    lo, hi = _wilson(h, n)
    return f"{h / n:.2f} ({h}/{n}) [{lo:.2f}, {hi:.2f}]"


def test_the_demo_paragraph_states_what_the_pairs_say() -> None:
    metrics = read_metrics_json(DEMO / "metrics.json")
    ate, _ = read_ate(DEMO / "ate.json")
    text = lead_paragraph(metrics, ate)[0]
    counts, _ = _by_hand()
    n = next(iter(counts.values()))["max recall"][1]
    assert text.startswith(f"**Cross-robot pairs, {n} relevant.**")
    cell = r"\d\.\d\d \(\d+/\d+\) \[\d\.\d\d, \d\.\d\d\]"
    said = re.findall(
        rf"At (max recall|precision >= 0\.9|acceptance \(k = \d+\)) (.+?) leads?(?:, each)? with ({cell})"
        r"(?:, (?:its|their) intervals? above (?:that|those) of ([^.]+?))?(?:,? but not separated from (.+?))?"
        r"\.(?= At | The | ATE )",
        text,
    )
    assert [s[0] for s in said] == list(next(iter(counts.values())))
    for point, leaders, cell, above, overlapping in said:
        hits = {m: c[point][0] for m, c in counts.items()}
        top = max(hits.values())
        assert sorted(leaders.split(" and ")) == sorted(m for m, h in hits.items() if h == top), point
        assert cell == _cell(top, n)
        low = _wilson(top, n)[0]
        rest = [m for m in sorted(hits, key=lambda m: (-hits[m], m)) if hits[m] < top]
        sep = [m for m in rest if _wilson(hits[m], n)[1] < low]
        assert re.split(r", | and ", above) == sep if above else not sep, point
        others = [m for m in rest if m not in sep]
        assert overlapping == " and ".join(f"{m} ({_cell(hits[m], n)})" for m in others), point
    # the demo: roman leads alone at max recall, at P >= 0.9 and at acceptance
    assert [s[1] for s in said] == ["roman", "roman", "roman"]
    odo, rom = (ate.rmse(v, "se3", "all") for v in ("odometry", "roman"))
    assert odo is not None and rom is not None
    assert f"odometry {odo:.2f} m; pose graphs: roman's {rom:.2f} m ({rom / odo:.0%} of odometry's)" in text
    assert "The order by hits changes between operating points (max recall: roman > ransac100k" in text


def test_the_report_opens_with_the_paragraph_then_the_headline_plots() -> None:
    metrics = read_metrics_json(DEMO / "metrics.json")
    plots = ["plots/map_view.png", "plots/recall_heading.png", "plots/trajectories.png"]
    notes = ["plot recall_ambiguity.png not drawn: it needs two ambiguity bins with relevant pairs"]
    text = report_markdown("demo", metrics, None, None, notes=notes, plots=plots)
    lines = text.splitlines()
    assert lines[0] == "# Evaluation report: demo" and lines[2].startswith("**Cross-robot pairs, 44 relevant.** At max")
    assert text.index("## Headline plots") < text.index("(plots/recall_heading.png)") < text.index("## What was scored")
    assert text.index("(plots/trajectories.png)") < text.index("## Alignment") < text.index("(plots/map_view.png)")
    more = text[text.index("## More plots") :]
    assert "- plot recall_ambiguity.png not drawn: it needs two ambiguity bins with relevant pairs" in more
    # bins with fewer than 5 relevant pairs are folded, and so is the same-robot section (2 relevant)
    assert "<details><summary>10 rows with fewer than 5 relevant pairs</summary>" in text
    assert "| roman | 60-120 deg | 4 |" in text.split("<details><summary>10 rows")[1].split("</details>")[0]
    assert "<details><summary>Alignment, same-robot pairs: 2 relevant, fewer than 5 (tables folded)</summary>" in text
