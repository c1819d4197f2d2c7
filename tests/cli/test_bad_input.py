"""The command line's bad-input suite (``roman_sim.cli``): every case is one ``error:`` line, exit code 1, no
traceback, nothing accepted.

Cases cover configuration files, ``--set`` overrides, names of presets and methods, output
locations, world folders, run folders, sweeps and Dask addresses, and user plug-ins. All of
them fail before any stage runs, so the whole table takes a few seconds. ``{name}`` in an
argument is replaced by the path of the input file ``name`` written by ``inputs``.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import yaml

ROBOTS = "robots: [{name: a, path: {kind: road}}]\n"
FILES = {
    "malformed": "name: x\nrobots: [\n",
    "dup_top": "name: x\nseed: 1\nseed: 2\n" + ROBOTS,
    "dup_nested": "name: x\nworld:\n  preset: tiny\n  preset: forest\n" + ROBOTS,
    "dup_flow": "name: x\nrobots: [{name: a, name: b}]\n",
    "unknown_top": "name: x\nsede: 1\n" + ROBOTS,
    "unknown_nested": "name: x\nrobots: [{name: a, camera: {fov: 90}}]\n",
    "nan_scalar": "name: x\nrobots: [{name: a, speed_mps: .nan}]\n",
    "inf_list": "name: x\nevaluation: {heading_bins_deg: [0, 90, .inf]}\n" + ROBOTS,
    "nan_tuple": "name: x\nmapping: {seg_plane_extents_m: [3, .nan, 0.5]}\n" + ROBOTS,
    "nan_waypoint": "name: x\nrobots: [{name: a, path: {kind: waypoints, waypoints: [[0, 0], [.nan, 3]]}}]\n",
    "nan_world": "name: x\nworld: {preset: tiny, overrides: {extent_m: [.nan, 60]}}\n" + ROBOTS,
    "nan_params": "name: x\naligners: [{method: roman, params: {sigma: .nan}}]\n" + ROBOTS,
    "wrong_type": "name: x\nseed: three\n" + ROBOTS,
    "robots_scalar": "name: x\nrobots: 5\n",
    "robots_empty": "name: x\nrobots: []\n",
    "list_top": "- name: x\n",
    "empty": "",
    "same_robots": "name: x\nrobots: [{name: a}, {name: a}]\n",
    "bad_posegraph": "name: x\nposegraph_method: ransac1m\n" + ROBOTS,
    "bad_bins": "name: x\nevaluation: {heading_bins_deg: [0, 120, 60]}\n" + ROBOTS,
    "sweep_nan": "name: s\nscenario: smoke\ngrid: {robots.0.speed_mps: [1.0, .nan]}\n",
    "sweep_kind": "name: s\nscenario: smoke\nexecutor: {kind: cluster}\n",
    "sweep_dup": "name: s\nscenario: smoke\nseeds: [0]\nseeds: [1]\n",
    "sweep_timeout": "name: s\nscenario: smoke\nexecutor: {kind: dask, connect_timeout_s: 0}\n",
    "sweep_empty_grid": "name: s\nscenario: smoke\ngrid: {seed: []}\n",
}

CASES = [
    # scenario files
    (["run", "{malformed}"], "malformed YAML (line 3, column 1)"),
    (["run", "{dup_top}"], "duplicate key 'seed' (first at line 2, again at line 3)"),
    (["run", "{dup_nested}"], "duplicate key 'preset' (first at line 3, again at line 4)"),
    (["run", "{dup_flow}"], "duplicate key 'name'"),
    (["run", "{unknown_top}"], "sede: unknown key (allowed: aligners, description, evaluation, frontend,"),
    (["run", "{unknown_nested}"], "robots.0.camera.fov: unknown key (allowed: depth_noise, far_m, height,"),
    (["run", "{nan_scalar}"], "robots.0.speed_mps: must be a finite number (got nan)"),
    (["run", "{inf_list}"], "evaluation.heading_bins_deg.2: must be a finite number (got inf)"),
    (["run", "{nan_tuple}"], "mapping.seg_plane_extents_m.1: must be a finite number (got nan)"),
    (["run", "{nan_waypoint}"], "robots.0.path.waypoints.1.0: must be a finite number (got nan)"),
    (["run", "{nan_world}"], "world.overrides.extent_m.0: must be a finite number (got nan)"),
    (["run", "{nan_params}"], "aligners.0.params.sigma: must be a finite number (got nan)"),
    (
        ["run", "{wrong_type}"],
        "seed: Input should be a valid integer, unable to parse string as an integer (got 'three')",
    ),
    (["run", "{robots_scalar}"], "robots: Input should be a valid list (got 5)"),
    (["run", "{robots_empty}"], "robots: List should have at least 1 item"),
    (["run", "{list_top}"], "expected a mapping at the top level"),
    (["run", "{empty}"], "expected a mapping at the top level"),
    (["run", "{same_robots}"], "robots: names must be unique, got a, a"),
    (["run", "{bad_posegraph}"], "posegraph_method: 'ransac1m' is not among aligners (roman)"),
    (["run", "{bad_bins}"], "heading_bins_deg must hold at least 2 strictly increasing edges"),
    (["run", "{dir}"], "is a directory, expected a scenario YAML file"),
    (["run", "{dir}/nope.yaml"], "no such file or bundled scenario (bundled: ambiguity, demo"),
    (["run", "smokey"], "scenario 'smokey': no such file or bundled scenario"),
    # overrides
    (["run", "smoke", "--set", "robots.5.drift=poor"], "--set robots.5.drift: position 5 out of range: robots has 2"),
    (["run", "smoke", "--set", "robots.first.drift=poor"], "'first' is not a position in it (positions: 0..1)"),
    (["run", "smoke", "--set", "seed.value=3"], "--set seed.value: seed is a number (0), not a mapping or list"),
    (["run", "smoke", "--set", "seed"], "--set 'seed': expected key=value"),
    (["run", "smoke", "--set", "=3"], "empty key or empty part"),
    (["run", "smoke", "--set", "seed=[1"], "--set seed: value '[1': malformed YAML"),
    (["run", "smoke", "--set", "frontend={a: 1, a: 2}"], "duplicate key 'a'"),
    (["run", "smoke", "--set", "seed=-1"], "seed: Input should be greater than or equal to 0 (got -1)"),
    (["run", "smoke", "--set", "robots.0.speed_mps=inf"], "robots.0.speed_mps: must be a finite number (got 'inf')"),
    (["run", "smoke", "--set", "robots.0.camera.width=2"], "robots.0.camera.width: Input should be greater than"),
    (["run", "smoke", "--set", "robots.0.drift=wobbly"], "unknown drift preset 'wobbly' (valid: good, poor, typical"),
    (["run", "smoke", "--set", "world.preset=jungle"], "unknown world preset 'jungle' (valid:"),
    (
        ["run", "smoke", "--set", "frontend.segmenter=magic"],
        "unknown segmenter 'magic' (valid: fastsam, image, perfect, sam",
    ),
    (["run", "smoke", "--set", "frontend.segmenter=5"], "frontend.segmenter: expected a string or a mapping"),
    (["run", "smoke", "--set", "frontend.segmenter={miss_prob: 2}"], "frontend.segmenter.params: miss_prob:"),
    (["run", "smoke", "--set", "frontend.encoder=clap"], "frontend.encoder: unknown encoder 'clap'"),
    (["run", "smoke", "--set", "frontend.encoder=clip"], "frontend.encoder.params: weights: required"),
    (
        [
            "run",
            "smoke",
            "--set",
            "frontend.encoder={name: clip, params: {weights: /no/such}}",
            "--set",
            "robots.0.render_rgb=true",
            "--set",
            "robots.1.render_rgb=true",
        ],
        "frontend.encoder.params.weights: no model folder at /no/such",
    ),
    (
        ["run", "smoke", "--set", "frontend.encoder=image"],
        "robots.a.render_rgb: the front end's encoder 'image' needs RGB",
    ),
    (["run", "smoke", "--set", "world.overrides={extent_m: [5, 5]}"], "extent_m: each side must be in [10, 2000] m"),
    (["run", "smoke", "--aligner", "ransack"], "unknown aligner 'ransack' (valid:"),
    (["run", "smoke", "--from", "mapping"], "from_stage: unknown stage 'mapping' (valid: world, maps, submaps"),
    (["run", "smoke", "--submaps", "{dir}/none"], "--submaps {dir}/none: not a folder"),
    (["run", "smoke", "--out", "{taken}"], "{taken}"),
    # user plug-ins (imported from the current folder, as a user's module would be)
    (["run", "smoke", "--aligner", "syntax_error:Broken"], "importing 'syntax_error' raised SyntaxError"),
    (["run", "smoke", "--aligner", "raises_on_import:X"], "raised RuntimeError: licence server unreachable"),
    (["run", "smoke", "--aligner", "missing_dependency:X"], "No module named 'torch_that_is_not_installed'"),
    (["run", "smoke", "--aligner", "no_such_module:X"], "cannot import 'no_such_module'"),
    (["run", "smoke", "--aligner", "user_plugins:Missing"], "'user_plugins' has no attribute 'Missing'"),
    (["run", "smoke", "--aligner", "user_plugins:RaisesInInit"], "RaisesInInit() raised OSError: model weights not"),
    (["run", "smoke", "--aligner", "user_plugins:NoAlign"], "NoAlign has no method 'align'"),
    (["run", "smoke", "--aligner", "user_plugins:ReturnsNone"], "align(a, b) returned None, expected an AlignResult"),
    (["run", "smoke", "--aligner", "user_plugins:ReturnsDict"], "align(a, b) returned a dict, expected an AlignResult"),
    (["run", "smoke", "--aligner", "user_plugins:ReturnsStr"], "returned a str ('aligned'), expected an AlignResult"),
    (["run", "smoke", "--aligner", "user_plugins:AlwaysRaises"], "raised IndexError: list index out of range"),
    (["run", "smoke", "--set", "frontend.segmenter=user_plugins:ReturnsDict"], "segment(frame) returned a dict"),
    (["run", "smoke", "--set", "frontend.segmenter=user_plugins:AlwaysRaises"], "segmenter 'user_plugins:Alway"),
    (["run", "smoke", "--set", "frontend.encoder=user_plugins:ReturnsStr"], "encode(...) returned a str ('aligned')"),
    (["run", "smoke", "--set", "frontend.encoder=user_plugins:UnnormalisedEncoder"], "expected a unit vector"),
    # worlds
    (["world", "generate", "jungle", "--out", "{dir}/w"], "unknown world preset 'jungle'"),
    (["world", "generate", "tiny", "--out", "{taken}"], "--out {taken}: is an existing file, not a folder"),
    (["world", "generate", "tiny", "--set", "extent_m=[.nan, 50]", "--out", "{dir}/w"], "extent_m.0: must be a finite"),
    (["world", "generate", "tiny", "--set", "families.0.densty=3", "--out", "{dir}/w"], "families.0.densty: unknown"),
    (["world", "generate", "tiny", "--seed", "-3", "--out", "{dir}/w"], "seed must be a non-negative integer"),
    (["world", "preview", "tiny", "--out", "{taken}"], "--out {taken}: is an existing file, not a folder"),
    (["world", "preview", "tiny", "--out", "{dir}/folder.png"], "folder.png: is an existing folder, expected a file"),
    (["world", "preview", "{world_bad_json}", "--out", "{dir}/p.png"], "{world_bad_json}/truth.json: not valid JSON"),
    (["world", "preview", "{world_bad_xml}", "--out", "{dir}/p.png"], "{world_bad_xml}/world.xml: MuJoCo cannot load"),
    (["world", "preview", "{world_no_truth}", "--out", "{dir}/p.png"], "missing truth.json (not an exported world"),
    # run folders
    (["report", "{dir}"], "not a run folder"),
    (["report", "{bad_manifest}"], "{bad_manifest}/manifest.json: not valid JSON (line 1"),
    # recordings
    (["record", "smoke", "--out", "{taken}"], "--out {taken}: is an existing file, not a folder"),
    (["record", "smoke", "--robot", "c", "--out", "{dir}/r"], "--robot: no simulated robot c (simulated robots: a, b)"),
    # sweeps and Dask
    (["sweep", "{sweep_nan}"], "grid.robots.0.speed_mps.1: must be a finite number (got nan)"),
    (["sweep", "{sweep_kind}"], "executor.kind: Input should be 'serial', 'local' or 'dask'"),
    (["sweep", "{sweep_dup}"], "duplicate key 'seeds'"),
    (["sweep", "{sweep_timeout}"], "executor.connect_timeout_s: Input should be greater than 0"),
    (["sweep", "{sweep_empty_grid}", "--out", "{dir}/sw"], "grid.seed: needs at least one value"),
    (["sweep", "{dir}/none.yaml"], "file not found"),
    (["sweep", "{sweep_empty_grid}", "--scheduler", "not-a-url"], "Dask scheduler 'not-a-url': not an address"),
    (["sweep", "{sweep_empty_grid}", "--scheduler", "http://localhost:8787"], "unknown scheme 'http'"),
    (["sweep", "{sweep_empty_grid}", "--workers", "0"], "workers: Input should be greater than or equal to 1"),
    (["list", "robots"], "unknown 'robots' (valid:"),
]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory, tiny_exported: Path) -> dict[str, str]:
    d = tmp_path_factory.mktemp("inputs")
    paths = {"dir": str(d)}
    for name, text in FILES.items():
        (d / f"{name}.yaml").write_text(text)
        paths[name] = str(d / f"{name}.yaml")
    (d / "taken").write_text("a file the user wants kept")
    (d / "folder.png").mkdir()
    paths["taken"] = str(d / "taken")
    for name, corrupt in (
        ("world_bad_json", ("truth.json", '{"objects": [')),
        ("world_bad_xml", ("world.xml", "<mujoco><worldbody>")),
    ):
        shutil.copytree(tiny_exported, d / name)
        (d / name / corrupt[0]).write_text(corrupt[1])
        paths[name] = str(d / name)
    shutil.copytree(tiny_exported, d / "world_no_truth")
    (d / "world_no_truth" / "truth.json").unlink()
    paths["world_no_truth"] = str(d / "world_no_truth")
    (d / "bad_manifest").mkdir()
    (d / "bad_manifest" / "manifest.json").write_text("{not json")
    paths["bad_manifest"] = str(d / "bad_manifest")
    return paths


@pytest.fixture(scope="module")
def tiny_exported(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from roman_sim.world import export_world, generate, load_world_spec

    out = tmp_path_factory.mktemp("tiny") / "world"
    export_world(generate(load_world_spec("tiny"), 0), out)
    return out


def _fill(text: str, paths: dict[str, str]) -> str:
    for k, v in paths.items():
        text = text.replace("{" + k + "}", v)
    return text


@pytest.mark.parametrize(("args", "expect"), CASES, ids=[" ".join(a)[:60] for a, _ in CASES])
def test_bad_input_is_one_line_and_exit_code_1(
    home: Path, inputs: dict[str, str], cli_fails, args: list[str], expect: str
) -> None:
    args = [_fill(a, inputs) for a in args]
    if args[0] == "run" and "--out" not in args:
        args += ["--out", f"{inputs['dir']}/out"]
    line = cli_fails(*args)
    assert _fill(expect, inputs) in line, line
    assert not Path(inputs["dir"], "out").exists(), "a run started"
    assert Path(inputs["taken"]).read_text() == "a file the user wants kept"


def test_the_suite_is_large(inputs: dict[str, str]) -> None:
    """Every input file is used by some case, and the table holds many cases."""
    used = {k for k in inputs if any("{" + k + "}" in " ".join(a) for a, _ in CASES)}
    assert set(FILES) <= used
    assert len(CASES) >= 80


def test_files_are_what_they_claim() -> None:
    """The duplicate-key files are otherwise valid YAML (so the duplicate is what is reported)."""
    for name in ("dup_top", "dup_nested", "sweep_dup"):
        assert isinstance(yaml.safe_load(FILES[name]), dict)
    assert json.loads(json.dumps(CASES))  # plain data only
