"""The paper-scale page's generated block follows from the committed reference runs and benchmark figures."""

from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path

from committed_results import BENCHMARKS_OUT, REFERENCE, copy_committed

ROOT = Path(__file__).resolve().parent.parent


def _module():
    spec = importlib.util.spec_from_file_location("readme_scale", ROOT / "benchmarks" / "readme_scale.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_page_block_is_rendered_from_the_committed_files():
    mod = _module()
    text = (ROOT / mod.PAGE).read_text(encoding="utf-8")
    block = text[text.index(mod.BEGIN) : text.index(mod.END) + len(mod.END)]
    assert block == mod.render(ROOT), "run: python benchmarks/readme_scale.py"


def _fake_run(root: Path, name: str, robots: int, km: float, maps_s: float, pairs: int) -> None:
    d = root / "results" / "reference" / name
    d.mkdir(parents=True)
    stages = {
        "world": {"seconds": 10.0},
        "maps": {"seconds": maps_s},
        "submaps": {"seconds": 5.0},
        "evaluation": {
            "seconds": 50.0,
            "pairs": {"workers": 2, "executor": "local"},
            "alignment": {"roman": {"mean": 0.004}, "clipper": {"mean": 0.006}},
        },
        "posegraph": {"seconds": 3.0},
        "report": {"seconds": 2.0},
    }
    (d / "timings.json").write_text(json.dumps({"stages": stages}))
    (d / "map_stats.json").write_text(json.dumps({"robots": robots, "trajectory_km": km, "submaps": 100}))
    (d / "metrics.json").write_text(
        json.dumps(
            {"n_pairs": pairs, "n_candidates": 4 * pairs, "n_skipped": 3 * pairs, "config": {"max_pair_dist_m": 30.0}}
        )
    )


def test_cost_model_by_hand(tmp_path):
    """m = maps s / km of the longest run, a = sum of the methods' mean seconds per pair."""
    mod = _module()
    _fake_run(tmp_path, "kimera_hybrid", 7, 6.0, 1200.0, 6000)
    _fake_run(tmp_path, "kimera_outdoor", 8, 8.0, 1600.0, 8000)
    (tmp_path / "benchmarks" / "out").mkdir(parents=True)
    (tmp_path / "benchmarks" / "out" / "scale.json").write_text("{}")
    out = mod.render(tmp_path)
    # m = 1600 / 8 = 200 s per km; a = 0.010 s per pair; 1000 pairs per km
    assert "mapping m = 200 s per km" in out and "a = 10.0 s per 1000 pairs" in out
    assert "1000 candidate pairs per km" in out
    # 1x on one worker: 8 km x 200 s + 8000 x 0.01 s = 1680 s = 28 min
    assert "| 1x `kimera_outdoor` (8 robots) | 8 | 8000 | 28 min |" in out
    # 10x: one worker 80 km x 200 s + 80000 x 0.01 s = 16800 s; 10 workers a tenth of it, 1680 s
    assert "| 10x `kimera_outdoor` (80 robots) | 80 | 80000 | 4.7 h | 28 min |" in out
    # the runs table: total = 10 + 1600 + 5 + 50 + 3 + 2 s = 1670 s
    row = "| `kimera_outdoor` | 8 | 8.0 | 100 | 8000 (of 32000; 30 m) | 27 min | 50 s | 20 s | 28 min | 2 (local) |"
    assert row in out


def test_update_rewrites_only_the_block(tmp_path):
    mod = _module()
    copy_committed(REFERENCE, tmp_path / "results" / "reference", ignore=("*.gz", "*.png", "*.csv"))
    (tmp_path / "benchmarks" / "out").mkdir(parents=True)
    shutil.copyfile(BENCHMARKS_OUT / "scale.json", tmp_path / "benchmarks" / "out" / "scale.json")
    page = tmp_path / mod.PAGE
    page.parent.mkdir()
    page.write_text(f"before\n{mod.BEGIN}\nstale\n{mod.END}\nafter\n")
    mod.update(tmp_path)
    text = page.read_text()
    assert text.startswith("before\n") and text.endswith("\nafter\n") and "stale" not in text
    assert mod.render(tmp_path) in text


def test_segments_per_submap_are_the_committed_packets():
    import re
    import statistics

    import numpy as np

    text = " ".join((ROOT / "docs" / "paper_scale.md").read_text(encoding="utf-8").split())
    m = re.search(r"Segments per submap \(median over the submap packets .*? demo's (\d+) ", text)
    assert m, "docs/paper_scale.md states the segments per submap"
    stated = {run: median for run, median, _ in re.findall(r"`(kimera_\w+)` (\d+) \((\d+) submaps\)", text)}
    runs = {p.parent.name for p in REFERENCE.glob("kimera_*/packets")}
    assert set(stated) == runs  # every committed paper-scale run, no other
    for run in [*sorted(runs), "demo"]:
        counts = []
        for f in sorted((REFERENCE / run / "packets").glob("*.npz")):
            with np.load(f) as z:
                counts += [len(z[k]) for k in z.files if k.endswith("_segment_ids")]
        want = m[1] if run == "demo" else stated[run]
        assert str(round(statistics.median(counts))) == want, run
        if run != "demo":
            assert statistics.median(counts) >= 10, run  # as full as the demo's: at least 10
            assert re.search(rf"`{run}` \d+ \({len(counts)} submaps\)", text), run
