"""Front-end configuration: named components with params, registries, flags and factories."""

import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.frontend.components import (
    ENCODER_TYPES,
    SEGMENTER_TYPES,
    FrontEndConfig,
    build_encoder,
    build_segmenter,
    check_robots,
    encoder_spec,
    segmenter_spec,
)
from roman_sim.frontend.image_encoder import ImageEncoder
from roman_sim.frontend.image_segmenter import ImageSegmenter
from roman_sim.frontend.segmenter import SimulatedSegmenter
from roman_sim.frontend.semantics import SemanticConfig, SimulatedEncoder
from roman_sim.mapping.protocols import reads_truth
from roman_sim.pipeline.scenario import FrontEnd as ScenarioFrontEnd
from roman_sim.pipeline.scenario import load_scenario


class Robot:
    def __init__(self, name, render_rgb):
        self.name, self.render_rgb = name, render_rgb


class UserSegmenter:
    needs_rgb = True

    def __init__(self, k=1):
        self.k = k

    def segment(self, frame):
        return []


def test_registries_and_flags():
    assert SEGMENTER_TYPES.names() == ["fastsam", "image", "perfect", "sam"]
    assert ENCODER_TYPES.names() == ["clip", "dinov2", "image", "simulated"]
    truth = {n for n in SEGMENTER_TYPES.names() if SEGMENTER_TYPES.get(n).reads_truth}
    assert truth == {"fastsam", "perfect"}
    assert {n for n in ENCODER_TYPES.names() if ENCODER_TYPES.get(n).reads_truth} == {"simulated"}
    rgb = {n for n in ENCODER_TYPES.names() if ENCODER_TYPES.get(n).needs_rgb}
    assert rgb == {"clip", "dinov2", "image"}
    assert segmenter_spec(f"{__name__}:UserSegmenter").needs_rgb
    assert not segmenter_spec(f"{__name__}:UserSegmenter").reads_truth


def test_entries_accept_names_and_params():
    assert issubclass(ScenarioFrontEnd, FrontEndConfig) and "keyframes" in ScenarioFrontEnd.model_fields
    fe = validate_model(FrontEndConfig, {"segmenter": "image", "encoder": {"name": "image", "params": {"l_bins": 3}}})
    assert (fe.segmenter.name, fe.segmenter.params, fe.encoder.params) == ("image", {}, {"l_bins": 3})
    assert fe.needs_rgb and not fe.reads_truth
    default = FrontEndConfig()
    assert (default.segmenter.name, default.encoder.name) == ("fastsam", "simulated")
    assert default.reads_truth and not default.needs_rgb
    # Calibration output: params without a name mean the fastsam error model.
    assert validate_model(FrontEndConfig, {"segmenter": {"params": {"miss_prob": 0.2}}}).segmenter.name == "fastsam"


@pytest.mark.parametrize(
    "data, match",
    [
        (
            {"segmenter": "sam9"},
            r"segmenter: unknown segmenter 'sam9' \(valid: fastsam, image, perfect, sam",
        ),
        ({"encoder": "clap"}, r"unknown encoder 'clap' \(valid: clip, dinov2, image, simulated"),
        ({"segmenter": {"name": "image", "params": {"scale": -1}}}, r"frontend.segmenter.params: scale"),
        ({"segmenter": {"name": "fastsam", "params": {"miss": 1}}}, r"frontend.segmenter.params: miss: unknown key"),
        ({"encoder": {"name": "clip", "params": {}}}, r"frontend.encoder.params: weights: required"),
        ({"encoder": {"name": "simulated", "params": {"dim": 8}}}, r"frontend.encoder.params: dim: unknown key"),
        ({"encoder": {"nam": "image"}}, r"encoder.nam: unknown key"),
    ],
)
def test_bad_entries_are_one_line_errors(data, match):
    with pytest.raises(ConfigError, match=match) as err:
        validate_model(FrontEndConfig, data, source="frontend")
    assert "\n" not in str(err.value)


def test_factories_build_the_components():
    fe = FrontEndConfig(segmenter={"name": "perfect", "params": {"erosion_px": 1}}, semantics=SemanticConfig(dim=16))
    seg = build_segmenter(fe, seed=3, robot="a")
    assert isinstance(seg, SimulatedSegmenter) and seg.cfg.erosion_px == 1 and seg.cfg.miss_prob == 0
    assert seg.seed == 3 and reads_truth(seg)
    enc = build_encoder(fe, seed=3, robot="a", families={1: "rock"})
    assert isinstance(enc, SimulatedEncoder) and enc.cfg.dim == 16 and enc.families == {1: "rock"}
    assert isinstance(build_segmenter("image"), ImageSegmenter)
    img = build_encoder({"name": "image", "params": {"orient_bins": 4}}, families={1: "rock"})
    assert isinstance(img, ImageEncoder) and img.cfg.orient_bins == 4 and not reads_truth(img)
    user = build_segmenter({"name": f"{__name__}:UserSegmenter", "params": {"k": 5}})
    assert isinstance(user, UserSegmenter) and user.k == 5
    with pytest.raises(ConfigError, match="cannot construct it"):
        build_segmenter({"name": f"{__name__}:UserSegmenter", "params": {"nope": 5}})
    with pytest.raises(ConfigError, match="cannot import"):
        build_segmenter("no_such_pkg.mod:Seg")


def test_model_adapters_need_a_local_folder(tmp_path):
    for entry, field in (
        ({"name": "clip", "params": {"weights": str(tmp_path / "none")}}, "frontend.encoder.params.weights"),
        ({"name": "dinov2", "params": {"weights": str(tmp_path)}}, "frontend.encoder.params.weights"),
    ):
        with pytest.raises(ConfigError, match=field) as err:
            build_encoder(entry)
        assert "\n" not in str(err.value)
    with pytest.raises(ConfigError, match="frontend.segmenter.params.weights: no model folder"):
        build_segmenter({"name": "sam", "params": {"weights": str(tmp_path / "none")}})


def test_rgb_check_names_the_robot():
    fe = FrontEndConfig(segmenter="image", encoder="simulated")
    check_robots(fe, [Robot("a", True)])
    with pytest.raises(ConfigError, match=r"robots.b.render_rgb: the front end's segmenter 'image' needs RGB"):
        check_robots(fe, [Robot("a", True), Robot("b", False)])
    check_robots(FrontEndConfig(), [Robot("a", False)])
    with pytest.raises(ConfigError, match="UserSegmenter"):
        check_robots(FrontEndConfig(segmenter=f"{__name__}:UserSegmenter"), [Robot("c", False)])
    assert encoder_spec("image").needs_rgb


def test_scenario_overrides_select_components():
    sc = load_scenario("smoke", ["frontend.segmenter={name: image, params: {scale: 50}}", "frontend.encoder=image"])
    assert sc.frontend.segmenter.params == {"scale": 50.0} or sc.frontend.segmenter.params == {"scale": 50}
    assert sc.frontend.encoder.name == "image"
    with pytest.raises(ConfigError, match="frontend.segmenter"):
        load_scenario("smoke", ["frontend.segmenter=sam9"])


@pytest.mark.parametrize(
    "override, field",
    [
        ("frontend.semantics.confusion.other.mean=1.2", "frontend.semantics.confusion.other.mean"),
        ("frontend.semantics.confusion.same_group.std=-0.1", "frontend.semantics.confusion.same_group.std"),
        ("frontend.semantics.confusion.same_instance.mean_same_view=-2", "mean_same_view"),
        ("frontend.semantics.confusion=-1", "frontend.semantics.confusion.level"),
        ("frontend.segmenter={params: {undersegment_prob: 1.5}}", "frontend.segmenter.params: undersegment_prob"),
        ("frontend.segmenter={params: {view_split_frac: -0.1}}", "frontend.segmenter.params: view_split_frac"),
        ("frontend.segmenter={params: {partial_frac: 2}}", "frontend.segmenter.params: partial_frac"),
        ("frontend.severity=-1", "frontend.severity"),
        ("frontend.preset=nope", "frontend.preset: unknown preset 'nope'"),
    ],
)
def test_bad_front_end_values_fail_with_one_line_naming_the_field(override, field):
    with pytest.raises(ConfigError) as err:
        load_scenario("smoke", [override])
    msg = str(err.value)
    assert field in msg and "\n" not in msg, msg


def test_confusion_sweeps_as_one_number():
    sc = load_scenario("smoke", ["frontend.semantics.confusion=0.5"])
    assert sc.frontend.semantics.confusion.level == 0.5
    assert sc.frontend.semantics.confusion.other.std == SemanticConfig().confusion.other.std
    sc = load_scenario("smoke", ["frontend.semantics.confusion.level=1.2"])
    assert build_encoder(sc.frontend, families={}).layout == sc.frontend.semantics.confusion.layout()


def test_confusion_is_a_sweep_axis():
    from roman_sim.pipeline.sweep_spec import SweepConfig, expand

    cfg = SweepConfig(name="c", scenario="smoke", grid={"frontend.semantics.confusion": [0.0, 0.5, 1.0]})
    levels = [load_scenario("smoke", list(r.overrides)).frontend.semantics.confusion.level for r in expand(cfg)]
    assert levels == [0.0, 0.5, 1.0]


def test_package_exports_resolve_to_their_modules():
    import roman_sim.frontend
    import roman_sim.mapping

    for pkg in (roman_sim.mapping, roman_sim.frontend):
        for name in pkg.__all__:
            obj = getattr(pkg, name)
            assert getattr(obj, "__name__", name) == name or not callable(obj), (pkg.__name__, name)
    assert roman_sim.mapping.Segmenter.__module__ == "roman_sim.mapping.protocols"
    assert roman_sim.frontend.SimulatedSegmenter.__module__ == "roman_sim.frontend.segmenter"
    with pytest.raises(AttributeError, match="SimulatedEncoder"):
        _ = roman_sim.mapping.SimulatedEncoder  # the front ends live in roman_sim.frontend


@pytest.mark.parametrize("switch", ["view_dependence", "lighting"])
@pytest.mark.parametrize("encoder", ["image", "mypkg.encoders:Clip"])
def test_simulated_switches_fail_on_an_encoder_that_cannot_honour_them(switch, encoder):
    with pytest.raises(ConfigError) as err:
        validate_model(FrontEndConfig, {"encoder": encoder, "semantics": {switch: False}}, source="frontend")
    what = switch.replace("_", " ")
    assert str(err.value) == (
        f"frontend: semantics: {switch}: false is allowed only with the simulated encoder "
        f"(encoder {encoder!r} has no simulated {what}); allowed: true"
    )
    # on: nothing to honour; off with the simulated encoder: switched off
    on = validate_model(FrontEndConfig, {"encoder": encoder, "semantics": {switch: True}})
    assert on.semantics.switched_off() == []
    sc = load_scenario("smoke", [f"frontend.semantics.{switch}=false"])
    assert sc.frontend.semantics.switched_off() == [switch]
