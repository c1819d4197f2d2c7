"""docs/mapping.md's appearance, view and light figures, re-derived from code and committed raw files."""

import json
import re
from pathlib import Path

import pytest
from committed_results import BENCHMARKS_OUT as OUT

from roman_sim.frontend.appearance import AppearanceModel
from roman_sim.frontend.semantics import SemanticConfig
from roman_sim.interop.looks import shape_asymmetry
from roman_sim.world.assets import FAMILIES

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "mapping.md").read_text(encoding="utf-8")


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


def test_lighting_figures_come_from_the_committed_measurement():
    m = json.loads((OUT / "lighting_fall.json").read_text(encoding="utf-8"))
    noon, pre = m["presets"]["noon"], m["presets"]
    per = noon["per_family"].values()
    cfg = SemanticConfig()
    si = cfg.confusion.same_instance
    fall = si.mean_same_view - si.mean_opposite_view
    text = " ".join(DOC.split())
    claims = [
        f"(sun {noon['sun']:g}, ambient {noon['ambient']:g}, headlight {noon['headlight']:g}: a sun share of "
        f"{noon['sun_share']:g})",
        f"by 1 - cosine {m['one_minus_cos']:.3f} (mean over families and {len(m['views'])} views; "
        f"{min(per):.3f} to {max(per):.3f} per family)",
        f"the drop at full strength, that is {m['lighting_fall']:.2f}.",
        f"give {pre['morning']['per_share']:.2f} and {pre['evening']['per_share']:.2f} over their shares, the "
        f"overcast sky (share {pre['overcast']['sun_share']:.2f}) {pre['overcast']['per_share']:.2f}",
        f"The default {cfg.lighting_fall:g} predates the measurement and is "
        f"{round(m['lighting_fall'] / cfg.lighting_fall):d} times smaller",
        f"the whole same-instance fall ({fall:.2f})",
        f"the colour block alone gives {m['blocks']['colour']:.2f}, the gradient and texture blocks "
        f"{m['blocks']['orient']:.3f} and {m['blocks']['lbp']:.3f}",
        f"use {cfg.lighting_fall:g}.",
    ]
    for claim in claims:
        assert claim in text, claim
    assert m["configured_default"] == cfg.lighting_fall and m["preset"] == "noon"
    assert m["lighting_fall"] == pytest.approx(m["one_minus_cos"] / m["sun_share"])
    assert m["lighting_fall"] > fall  # "cannot be configured as it stands"
    assert pre["overcast"]["per_share"] < m["lighting_fall"] / 1.5  # "not linear in the share"
    assert m["blocks"]["colour"] > 10 * max(m["blocks"]["orient"], m["blocks"]["lbp"])  # "almost all of it"
    with pytest.raises(ValueError, match="lighting_fall"):
        SemanticConfig(lighting_fall=round(m["lighting_fall"], 2))
    desc = SemanticConfig.model_fields["lighting_fall"].description or ""
    assert f"{m['lighting_fall']:.2f} with the pixel encoder" in desc and "predates the measurement" in desc
