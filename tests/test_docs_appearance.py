"""docs/mapping.md's appearance, view and light figures, re-derived from code and committed raw files."""

import json
import re
from pathlib import Path

import pytest

from roman_sim.frontend.appearance import AppearanceModel
from roman_sim.frontend.semantics import SemanticConfig
from roman_sim.interop.looks import shape_asymmetry
from roman_sim.world.assets import FAMILIES

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "mapping.md").read_text(encoding="utf-8")
OUT = ROOT / "benchmarks" / "out"


def test_view_asymmetry_table_is_re_derived_from_the_shapes():
    block = DOC.split("<!-- view-asymmetry:begin -->")[1].split("<!-- view-asymmetry:end -->")[0]
    rows = [r.strip("| ").split(" | ") for r in block.strip().splitlines()[2:]]
    assert [r[0] for r in rows] == FAMILIES.names()
    ref = SemanticConfig().view_reference
    for fam, *cells in rows:
        got = [shape_asymmetry(0, fam, v) for v in range(3)]
        assert [float(c) for c in cells[:3]] == [round(x, 3) for x in got], fam
        assert float(cells[3]) == round(min(1.0, sum(got) / 3 / ref), 2), fam


def test_appearance_weights_come_from_the_committed_measurement():
    m = json.loads((OUT / "appearance_weights.json").read_text(encoding="utf-8"))
    one = m["one_minus_cos"]
    text = " ".join(DOC.split())
    claim = (
        f"moves by 1 - cosine {one['shape']:.3f} for another shape variant, {one['scale']:.3f} for the smallest "
        f"against the largest scale, {one['colour']:.3f} for the two ends of a colour range and "
        f"{one['texture']:.3f} for another region of one texture"
    )
    assert claim in text
    model = AppearanceModel()
    for k in ("shape", "scale", "colour", "texture"):
        assert getattr(model, k) == pytest.approx(round(m["weights"][k], 2)), k
    assert "normalised and rounded, " + ", ".join(f"{getattr(model, k):.2f}" for k in ("shape", "scale")) in text


def test_no_identity_figure_is_the_committed_measurement():
    m = json.loads((OUT / "no_identity.json").read_text(encoding="utf-8"))
    s, o = m["same_instance"], m["other_instance"]
    text = " ".join(DOC.split())
    found = re.search(
        r"within 45 deg\), is ([0-9.]+) \((\d+) of (\d+) against (\d+) of (\d+); (\d+) observations", text
    )
    assert found, "no-identity sentence"
    ratio, sp, sn, op, on, nobs = found.groups()
    assert float(ratio) == round(m["ratio"], 2) and m["ratio"] <= 1.5
    assert (int(sp), int(sn), int(op), int(on)) == (s["pass"], s["pairs"], o["pass"], o["pairs"])
    assert int(nobs) == m["observations"] and m["within_deg"] == 45.0 and m["ambiguity"] == 1.0
    assert m["ratio"] == pytest.approx((s["pass"] / s["pairs"]) / (o["pass"] / o["pairs"]))
