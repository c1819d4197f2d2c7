"""The figures the docs state about a refused run and about large closure files follow from the
committed benchmark figures (``benchmarks/bench_refusal.py``, ``benchmarks/bench_closures.py``)."""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _page(name: str) -> str:
    return " ".join((ROOT / "docs" / name).read_text(encoding="utf-8").split())


def _bench(name: str) -> dict:
    return json.loads((ROOT / "benchmarks" / "out" / name).read_text(encoding="utf-8"))


def test_the_refusal_time_is_the_benchmarks() -> None:
    refusal = _bench("refusal.json")
    bench = refusal["cases"]
    m = re.search(
        r"A refused run takes (\d+\.\d) s of CPU with `--out` and (\d+\.\d) s for the default folder "
        r"\(medians of (\d+) refusals",
        _page("robustness.md"),
    )
    assert m, "docs/robustness.md no longer states the time a refused run takes"
    assert float(m[1]) == round(bench["out_given"]["cpu_s_median"], 1)
    assert float(m[2]) == round(bench["default_folder"]["cpu_s_median"], 1)
    assert int(m[3]) == bench["out_given"]["n"] == bench["default_folder"]["n"]
    assert bench["default_folder"]["cpu_s_median"] < refusal["target_s"]


def test_the_closure_file_figures_are_the_benchmarks() -> None:
    b = _bench("closures.json")
    m = re.search(
        r"a (\d+) MB CSV file of ([\d,]+) closures is read in (\d+) s of CPU with a peak of (\d+) MB of memory "
        r"\((\d+) MB of it the imports\) and scored in (\d+) s with a peak of (\d+) MB; the former reader took "
        r"(\d+) s and (\d+) MB to read it, (\d+) s and (\d+) MB to score it",
        _page("interop.md"),
    )
    assert m, "docs/interop.md no longer states the figures of a large closure file"
    assert int(m[1]) == b["mb"] and int(m[2].replace(",", "")) == b["closures"]["csv"]
    figures = [int(g) for g in m.groups()[2:]]
    expected = [
        b["read_csv"]["cpu_s"],
        b["read_csv"]["peak_rss_mb"],
        b["imports"]["peak_rss_mb"],
        b["score_csv"]["cpu_s"],
        b["score_csv"]["peak_rss_mb"],
        b["former"]["read_csv"]["cpu_s"],
        b["former"]["read_csv"]["peak_rss_mb"],
        b["former"]["score_csv"]["cpu_s"],
        b["former"]["score_csv"]["peak_rss_mb"],
    ]
    assert figures == [round(x) for x in expected]
