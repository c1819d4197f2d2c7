"""A plug-in's pose graph: ``roman-sim run SCENARIO --aligner pkg.mod:Class --set posegraph_method=pkg.mod:Class``.

``posegraph_method`` names an aligner by its label (a plug-in's class name) or by its method
(``package.module:Class``); aligners given with ``--aligner`` count when the overrides are
checked. The pose graph then takes the plug-in's closures: the ones its own rows of
``pairs.csv`` hold, not ROMAN's.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import yaml

from roman_sim.core.errors import ConfigError
from roman_sim.pipeline.scenario import load_scenario

PLUGIN = "myteam.align:EveryOtherPair"  # ROMAN on every other pair (``USER_ALIGNERS``)
ROW = "EveryOtherPair"


def test_posegraph_method_names_an_aligner_by_its_method_or_its_label() -> None:
    by_method = load_scenario("smoke", [f"posegraph_method={PLUGIN}"], [PLUGIN])
    by_label = load_scenario("smoke", [f"posegraph_method={ROW}"], [PLUGIN])
    assert by_method.posegraph_method == by_label.posegraph_method == ROW
    assert [a.name for a in by_method.aligners] == ["roman", "clipper", ROW]
    assert by_method.config_hash() == by_label.config_hash()  # one run, one set of stage keys
    assert load_scenario("smoke", [], [PLUGIN, "roman"]).aligners == by_method.aligners  # roman: already there
    with pytest.raises(ConfigError, match=r"^--set posegraph_method=myteam.align:Other: .*'myteam.align:Other' is not"):
        load_scenario("smoke", ["posegraph_method=myteam.align:Other"], [PLUGIN])
    with pytest.raises(ConfigError, match=r"^--aligner myteam.align:roman: .*labels must be unique"):
        load_scenario("smoke", [], ["myteam.align:roman"])


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_the_pose_graph_takes_the_plugins_closures(user_package: Path, invoke_in) -> None:
    out = user_package / "run"
    res = invoke_in(
        user_package, "run", "smoke", "--aligner", PLUGIN, "--set", f"posegraph_method={PLUGIN}", "--out", str(out),
        "--executor", "serial",
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert yaml.safe_load((out / "config.yaml").read_text())["posegraph_method"] == ROW
    rows = list(csv.DictReader((out / "pairs.csv").open()))

    def estimated(method: str) -> list[tuple[str, int, str, int, int]]:
        """The pairs ``method`` gave a transform (``pairs.csv``: its errors are filled), in table order."""
        return sorted(
            (r["robot_a"], int(r["index_a"]), r["robot_b"], int(r["index_b"]), int(r["n_assoc"]))
            for r in rows
            if r["method"] == method and r["rot_err_deg"] != ""
        )

    mine, roman = estimated(ROW), estimated("roman")
    assert mine and set(mine) < set(roman)  # a part of ROMAN's: which graph got them shows
    graphs = json.loads((out / "posegraph.json").read_text())
    assert sorted(graphs) == sorted([ROW, "oracle"]) and graphs[ROW]["closures"] == len(mine)
    variants = {v["name"]: v for v in json.loads((out / "posegraph_estimates.json").read_text())["variants"]}
    used = sorted(
        (c["robot_a"], c["submap_a"], c["robot_b"], c["submap_b"], c["n_associations"])
        for c in variants[ROW]["closures"]
    )
    assert used == mine and variants[ROW]["source"] == ROW
    ate = {v["name"]: v for v in json.loads((out / "ate.json").read_text())["variants"]}
    assert ate[ROW]["description"] == f"pose graph with {ROW}'s loop closures" and "roman" not in ate
    assert ate[ROW]["connected"] and ate[ROW]["rmse"]["se3"]["common"] is not None
    assert (out / "trajectories" / f"a.{ROW}.tum").is_file()


def test_a_posegraph_method_that_is_no_aligner_fails_in_one_line(user_package: Path, invoke_in) -> None:
    res = invoke_in(user_package, "run", "smoke", "--aligner", PLUGIN, "--set", "posegraph_method=myteam.align:Other")
    assert res.exit_code == 1 and not (user_package / "results").exists()
    assert res.stderr.strip() == (
        "error: --set posegraph_method=myteam.align:Other: <root>: posegraph_method: 'myteam.align:Other' is not "
        f"among aligners (roman, clipper, {ROW})"
    )
