"""What the README and the docs pages say about the bundled scenarios, presets and methods holds.

Each statement is parsed from the page and checked against the registries (what
``roman-sim list`` shows) and the bundled scenario files, so a page that falls behind the
code fails here.
"""

from __future__ import annotations

import re
from pathlib import Path

from committed_results import REFERENCE

from roman_sim.cli.run import LISTINGS
from roman_sim.pipeline.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent


def _flat(path: str) -> str:
    return " ".join((ROOT / path).read_text(encoding="utf-8").split())


def _table_names(path: str, heading: str) -> set[str]:
    """Back-quoted names in the first column of the table under ``heading``."""
    text = (ROOT / path).read_text(encoding="utf-8")
    section = text[text.index(heading) :].split("\n## ")[0]
    rows = [ln for ln in section.splitlines() if ln.startswith("| `")]
    return {n for ln in rows for n in re.findall(r"`([\w/.]+)`", ln.split("|")[1])}


def test_scenario_table_lists_every_bundled_scenario():
    listed = _table_names("docs/scenarios.md", "## Bundled scenarios") - {"sweeps/ambiguity_sweep.yaml"}
    assert listed == set(LISTINGS["scenarios"]())


def test_world_presets_are_the_registered_ones():
    for page in ("docs/scenarios.md", "docs/index.md"):
        text = _flat(page)
        m = re.search(r"((?:`\w+`(?:, | and | or )){4,}`\w+`)", text[text.index("presets") :])
        assert m, page
        assert set(re.findall(r"`(\w+)`", m.group(1))) == set(LISTINGS["worlds"]()), page


def test_overview_names_every_method_segmenter_encoder_and_drift_preset():
    row = {
        ln.split("|")[1].strip(): ln for ln in (ROOT / "docs/index.md").read_text().splitlines() if ln.count("|") > 3
    }
    named = {k: set(re.findall(r"`(\w+)`", v)) for k, v in row.items()}
    assert set(LISTINGS["aligners"]()) <= named["alignment"]
    assert set(LISTINGS["segmenters"]()) | set(LISTINGS["encoders"]()) <= named["front ends"]
    assert set(LISTINGS["drift"]()) <= named["robots"]


def test_the_overview_and_the_api_index_name_every_package():
    """The overview's table has a row for every package but those the sentence under it names (``core``,
    ``cli``, ``examples``); the API index, one for every package and ``roman_sim.testing``."""
    packages = {p.parent.name for p in (ROOT / "roman_sim").glob("*/__init__.py")}
    rows = [ln for ln in (ROOT / "docs/index.md").read_text().splitlines() if ln.count("|") > 3]
    overview = [m for ln in rows for m in re.findall(r"`roman_sim\.(\w+)`", ln.split("|")[2])]
    assert len(overview) == len(set(overview))
    assert set(overview) | {"core", "cli", "examples"} == packages
    assert "(`core` at the base, `cli`, `viz`, `testing` and `examples` on top)" in _flat("docs/index.md")
    api_rows = [ln for ln in (ROOT / "docs/api/index.md").read_text().splitlines() if ln.startswith("| [`")]
    api = {m for ln in api_rows for m in re.findall(r"`roman_sim\.(\w+)`", ln.split("|")[1])}
    assert api == packages | {"testing"}


def test_readme_describes_the_demo():
    text = _flat("README.md")
    sc = load_scenario("demo")
    m = re.search(r"two robots drive an (\d+) x (\d+) m off-road loop in opposite directions at (\d+) x (\d+)", text)
    assert m, "README describes the demo"
    assert sc.world.preset == "offroad" and list(sc.world.overrides["extent_m"]) == [float(m[1]), float(m[2])]
    assert {(r.camera.width, r.camera.height) for r in sc.robots} == {(int(m[3]), int(m[4]))}
    assert [r.path.kind for r in sc.robots] == ["road", "reverse_of"]
    assert [a.method for a in sc.aligners] == ["roman", "clipper", "clipper_prune", "ransac100k", "visual"]
    assert "ROMAN is compared with CLIPPER, pruned CLIPPER, RANSAC-100K and visual features" in text
    assert f"`results/demo/seed{sc.seed}-<hash>/`" in text


def test_paper_scale_page_describes_the_kimera_scenarios():
    m = re.search(
        r"(\d+)-(\d+) robots on their own routes of [\d.]+-[\d.]+ km through a (\d+) x (\d+) m world",
        _flat("docs/paper_scale.md"),
    )
    assert m
    scens = [load_scenario(f"kimera_{env}") for env in ("tunnel", "hybrid", "outdoor")]
    assert (min(len(s.robots) for s in scens), max(len(s.robots) for s in scens)) == (int(m[1]), int(m[2]))
    assert {tuple(s.world.overrides["extent_m"]) for s in scens} == {(float(m[3]), float(m[4]))}
    assert {s.evaluation.max_pair_dist_m for s in scens} == {30.0}  # "the submap pairs within ... (30 m)"
    assert "`evaluation.max_pair_dist_m` (30 m)" in _flat("docs/paper_scale.md")


def test_visual_page_states_the_shipped_vocabulary():
    import json

    import numpy as np

    path = ROOT / "roman_sim" / "align" / "visual" / "data" / "orb_vocabulary.npz"
    m = re.search(
        r"orb_vocabulary.npz`, (\d+) KB: (\d+) words, .*?; k = (\d+), L = (\d+)\)\. Trained on (\d+) frames \((\d+) "
        r"per world\) of (\w+) worlds no scenario uses \(six presets at seeds (\d+)-(\d+), textured, under the "
        r"five lighting presets, noon twice\), ([\d,]+) descriptors",
        _flat("docs/visual.md"),
    )
    assert m, "docs/visual.md describes the shipped vocabulary"
    with np.load(path, allow_pickle=False) as d:
        header, words = json.loads(bytes(d["header"]).decode()), len(d["weights"])
    meta = header["meta"]
    assert round(path.stat().st_size / 1000) == int(m[1]) and words == int(m[2])
    assert (header["k"], header["L"]) == (int(m[3]), int(m[4]))
    worlds = meta["worlds"]
    assert meta["n_images"] == int(m[5]) == int(m[6]) * len(worlds) and m[7] == "six" and len(worlds) == 6
    assert len({w[0] for w in worlds}) == 6  # six presets
    assert sorted(w[2] for w in worlds) == ["evening", "morning", "noon", "noon", "overcast", "random"]
    assert [w[1] for w in worlds] == list(range(int(m[8]), int(m[9]) + 1))
    assert meta["n_descriptors"] == int(m[10].replace(",", ""))


def test_visual_page_states_what_the_visual_test_asserts():
    page, test = _flat("docs/visual.md"), (ROOT / "tests" / "pipeline" / "test_visual.py").read_text()
    assert "`tests/pipeline/test_visual.py` checks on seed 1 that:" in page and "SEEDS = [1]" in test
    assert "visual max recall at 120-180 deg is at most 0.05, and ROMAN's is at least 0.2 higher" in page
    assert 'visual_run.recall("visual", "120-180") <= 0.05' in test
    assert 'visual_run.recall("roman", "120-180") >= visual_run.recall("visual", "120-180") + 0.2' in test
    assert "visual max recall at 0-60 deg is at least 0.4" in page and '{"0-60": 0.4}' in test
    assert "at most 2 cm above ROMAN's, and below the visual graph's" in page
    assert 'ate["combined"] <= ate["roman"] + 0.02' in test and 'ate["combined"] < ate["visual"]' in test


def test_visual_page_states_the_heading_sweep_recall():
    import json

    m = re.search(
        r"in `heading_sweep` visual max recall at 0-60 deg is only (\d\.\d\d) \((\d+)/(\d+)\)", _flat("docs/visual.md")
    )
    assert m
    summary = json.loads((REFERENCE / "summary.json").read_text(encoding="utf-8"))
    cell = summary["runs"]["heading_sweep"]["methods"]["visual"]["inter"]["bins"]["0-60"]
    assert (round(cell["max_recall"], 2), cell["max_hits"], cell["n_relevant"]) == (float(m[1]), int(m[2]), int(m[3]))


def test_evaluation_page_states_the_defaults():
    from roman_sim.evaluation.config import EvalConfig

    page, cfg = _flat("docs/evaluation.md"), EvalConfig()
    m = re.search(r"intra-robot pair at least (\w+) submaps apart", page)
    assert m and {"two": 2, "three": 3}[m[1]] == cfg.intra_min_gap
    m = re.search(r"relevant when its true centres are within (\d+) m", page)
    assert m and float(m[1]) == cfg.relevant_dist_m
    m = re.search(r"correct within (\d+) deg and (\d+) m of the true relative pose", page)
    assert m and (float(m[1]), float(m[2])) == (cfg.rot_tol_deg, cfg.trans_tol_m)
    m = re.search(r"hits/relevant with a (\d+) % Wilson interval, and a bin with fewer than (\d+) relevant pairs", page)
    assert m and (int(m[1]) / 100, int(m[2])) == (cfg.interval_level, cfg.min_relevant)
    assert cfg.heading_bins_deg == [0.0, 60.0, 120.0, 180.0] and "0-60, 60-120 and 120-180 deg" in _flat(
        "docs/benchmark.md"
    )
    assert cfg.fine_heading_bin_deg == 30.0 and "fine 30 deg bins" in _flat("docs/benchmark.md")


def test_cluster_pages_state_the_connect_timeout():
    from roman_sim.runner.executor_base import ExecutorConfig

    timeout = ExecutorConfig().connect_timeout_s
    for page in ("docs/tls.md", "docs/robustness.md"):
        m = re.search(r"`executor.connect_timeout_s` \(default (\d+) s\)", _flat(page))
        assert m and float(m[1]) == timeout, page
