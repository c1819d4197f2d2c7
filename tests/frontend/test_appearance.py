"""Descriptors from appearance: no identity, lower cosines for instances drawn apart, view and light.

Ground truth is the model's own statement: the expected inner product of two instances'
appearance vectors is ``AppearanceModel.kernel`` (random features approximate it within
about 1/sqrt(dim)), and the view and light parts turn by the energies ``energies`` gives.
"""

import math

import numpy as np
import pytest

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError
from roman_sim.frontend.appearance import (
    AppearanceFeatures,
    AppearanceModel,
    InstanceLooks,
    PartLooks,
    SceneLight,
    SceneLooks,
)
from roman_sim.frontend.components import FrontEndConfig
from roman_sim.frontend.semantics import SemanticConfig, SimulatedEncoder
from roman_sim.interop.looks import shape_asymmetry, world_instances
from roman_sim.mapping.protocols import EncodeContext
from roman_sim.world import WorldSpec, generate, load_world_spec

M = np.ones((2, 2), bool)


def _looks(lab=(50.0, -40.0, 40.0), shape="bush_v0", scale=1.0, yaw=0.0, texture=None):
    return InstanceLooks("bush", shape, scale, yaw, (PartLooks("body", lab, 1.0, texture),), 32)


def _view(deg):
    return np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg)), 0.0])


def _encode(cfg, looks, oid, deg, robot="a"):
    """One observation, with the first draw of ``robot``'s noise stream (equal for every call)."""
    enc = SimulatedEncoder(
        cfg, seed=4, families={i: lk.family for i, lk in looks.instances.items()}, robot=robot, looks=looks
    )
    return enc.encode(None, M, EncodeContext(oid, view_dir=_view(deg)))


@pytest.fixture(scope="module")
def identical_world():
    """The tiny world at ambiguity 1 without colour variation or textures: every instance drawn alike."""
    data = load_world_spec("tiny").model_dump(mode="json")
    data.update(ambiguity=1.0)
    data["appearance"].update(instance_variation=0.0, textures=False)
    return generate(validate_model(WorldSpec, data, "tiny"), 0)


def test_swapping_two_identical_instances_leaves_the_descriptors_unchanged(identical_world):
    inst = world_instances(identical_world)
    fam = max(set(lk.family for lk in inst.values()), key=[lk.family for lk in inst.values()].count)
    a, b = [i for i, lk in inst.items() if lk.family == fam][:2]
    assert inst[a] == inst[b]  # the renderer draws them with the same values
    swapped = dict(inst)
    swapped[a], swapped[b] = inst[b], inst[a]
    views = np.linspace(0.0, 350.0, 8)
    for looks in (SceneLooks(inst, {}), SceneLooks(swapped, {})):
        da = np.stack([_encode(SemanticConfig(), looks, a, d) for d in views])
        db = np.stack([_encode(SemanticConfig(), looks, b, d) for d in views])
        # object a seen from every view gives exactly what object b gives from that view
        np.testing.assert_array_equal(da, db)
    # the cosine of two identical instances from one side equals two views of one instance
    one = _encode(SemanticConfig(), SceneLooks(inst, {}), a, 0.0, "r1") @ _encode(
        SemanticConfig(), SceneLooks(inst, {}), a, 0.0, "r2"
    )
    two = _encode(SemanticConfig(), SceneLooks(inst, {}), a, 0.0, "r1") @ _encode(
        SemanticConfig(), SceneLooks(inst, {}), b, 0.0, "r2"
    )
    assert float(one) == pytest.approx(float(two), abs=1e-6)


def test_instances_drawn_apart_get_lower_cosines_as_the_kernel_says():
    cfg = SemanticConfig(view_dependence=False)
    model = cfg.appearance
    base = _looks()
    ref = SemanticConfig().confusion.same_family.mean
    got, want = [], []
    for de in (0.0, 10.0, 20.0, 40.0, 80.0):
        other = _looks(lab=(50.0 + de, -40.0, 40.0))
        looks = SceneLooks({0: base, 1: other}, {})
        cs = []
        for seed in range(20):  # the instance part's subspace share spreads one world's cosine (same_family.std)
            enc = SimulatedEncoder(cfg, seed=seed, families={0: "bush", 1: "bush"}, looks=looks)
            cs.append(float(enc.static(0, "bush") @ enc.static(1, "bush")))
        got.append(float(np.mean(cs)))
        want.append(ref + enc.energies(base)[0] * model.kernel(base, other))
    assert all(x > y for x, y in zip(got, got[1:]))  # lower with every step of colour difference
    np.testing.assert_allclose(got, want, atol=0.01)
    # the colour kernel itself: exp(-dE^2 / (2 l^2)) of the colour weight's share
    w = model.colour / sum(model.weights())
    expect = 1 - w * (1 - math.exp(-(20.0**2) / (2 * model.colour_length**2)))
    assert model.kernel(base, _looks(lab=(70.0, -40.0, 40.0))) == pytest.approx(expect)
    # a different shape variant, scale or texture region lowers the kernel by its weight
    assert model.kernel(base, _looks(shape="bush_v1")) == pytest.approx(1 - (model.shape + model.scale) / 1.0)
    t0, t1 = _looks(texture=(0, 3.0, 4.0)), _looks(texture=(0, 19.0, 30.0))
    assert model.kernel(t0, t1) == pytest.approx(1 - model.texture, abs=1e-9)
    assert model.kernel(t0, _looks(texture=(1, 3.0, 4.0))) == pytest.approx(1 - model.texture)


def test_random_features_realise_the_kernel():
    model = AppearanceModel()
    feats = AppearanceFeatures(model, seed=2, dim=768)
    rng = np.random.default_rng(0)
    errs = []
    for _ in range(40):
        a = _looks(
            lab=tuple(rng.uniform(20, 80, 3)), scale=float(rng.uniform(0.7, 1.3)), texture=(0, *rng.uniform(0, 32, 2))
        )
        b = _looks(
            lab=tuple(rng.uniform(20, 80, 3)), scale=float(rng.uniform(0.7, 1.3)), texture=(0, *rng.uniform(0, 32, 2))
        )
        errs.append(float(feats.vector(a) @ feats.vector(b)) - model.kernel(a, b))
    assert abs(np.mean(errs)) < 0.02 and np.std(errs) < 0.06
    assert float(feats.vector(_looks()) @ feats.vector(_looks())) == pytest.approx(1.0)


@pytest.mark.parametrize("family, turns", [("conifer", False), ("car", True), ("bench", True)])
def test_view_part_follows_the_shape(family, turns):
    asym = shape_asymmetry(0, family, 0)
    looks = InstanceLooks(family, f"{family}_v0", 1.0, 0.5, (PartLooks("body", (50.0, 0.0, 0.0), 1.0),))
    scene = SceneLooks({0: looks}, {f"{family}_v0": asym})
    cfg = SemanticConfig()
    enc = SimulatedEncoder(cfg, seed=4, families={0: family}, looks=scene)
    view = enc.energies(looks)[1]
    assert view == pytest.approx(enc.layout.view * min(1.0, asym / cfg.view_reference))
    front, back = _encode(cfg, scene, 0, 10.0), _encode(cfg, scene, 0, 190.0)
    drop = 1.0 - float(front @ back)
    if turns:
        assert asym > 0.05 and drop > 0.02
    else:
        assert asym < 1e-6 and drop < 1e-6
    # the object's own frame: the same azimuth relative to its heading gives the same descriptor
    turned = SceneLooks({0: InstanceLooks(family, f"{family}_v0", 1.0, 1.5, looks.parts)}, scene.asymmetry)
    np.testing.assert_allclose(_encode(cfg, turned, 0, 10.0 + math.degrees(1.0)), front, atol=1e-6)


def test_light_term_front_lit_against_back_lit():
    looks = _looks()
    sun = SceneLight(sun_azimuth=0.0, sun_elevation=math.radians(20.0), sun_share=0.6)
    cfg = SemanticConfig(view_dependence=False, lighting_fall=0.1)
    scene = SceneLooks({0: looks}, {}, sun)
    enc = SimulatedEncoder(cfg, seed=4, families={0: "bush"}, looks=scene)
    light = enc.energies(looks)[2]
    assert light == pytest.approx(0.05 * 0.6 * math.cos(math.radians(20.0)))
    back_lit, front_lit = _encode(cfg, scene, 0, 0.0), _encode(cfg, scene, 0, 180.0)  # against the sun / sun behind
    v_back, v_front = back_lit.astype(np.float64), front_lit.astype(np.float64)
    assert 1.0 - v_back @ v_front == pytest.approx(2 * light, abs=2e-3)
    off = cfg.model_copy(update={"lighting": False})
    np.testing.assert_array_equal(_encode(off, scene, 0, 0.0), _encode(off, scene, 0, 180.0))


def test_a_strong_sun_takes_the_whole_view_energy_and_no_more():
    """Under a low morning sun the measured light (0.64 / 2 x 0.56) exceeds the view energy: the light
    takes all of it, the view part nothing, and front-lit against back-lit falls by the whole
    configured fall; the appearance part keeps its share."""
    looks = _looks()
    sun = SceneLight(sun_azimuth=0.0, sun_elevation=math.radians(20.0), sun_share=0.6)
    cfg = SemanticConfig()
    scene = SceneLooks({0: looks}, {looks.shape: 1.0}, sun)
    enc = SimulatedEncoder(cfg, seed=4, families={0: "bush"}, looks=scene)
    assert 0.5 * cfg.lighting_fall * sun.strength > enc.layout.view  # the measured light would be more
    appearance, view, light = enc.energies(looks)
    assert light == pytest.approx(enc.layout.view) and view == 0.0
    assert appearance == pytest.approx(enc.layout.instance.weight)
    back_lit, front_lit = _encode(cfg, scene, 0, 0.0), _encode(cfg, scene, 0, 180.0)
    si = cfg.confusion.same_instance
    fall = si.mean_same_view - si.mean_opposite_view
    assert 1.0 - back_lit.astype(np.float64) @ front_lit.astype(np.float64) == pytest.approx(fall, abs=2e-3)


@pytest.mark.parametrize(
    "semantics, message",
    [
        ({"appearance": {"colour": 1.5}}, "semantics.appearance.colour: Input should be less than or equal to 1"),
        (
            {"appearance": {"shape": 0, "scale": 0, "colour": 0, "texture": 0}},
            "semantics.appearance: shape, scale, colour and texture are all 0: at least one weight must be "
            "positive (each in [0, 1])",
        ),
        ({"appearance": {"colour_length": 0}}, "semantics.appearance.colour_length: Input should be greater than 0"),
        ({"view_reference": 0}, "semantics.view_reference: Input should be greater than 0"),
        ({"lighting_fall": 2.5}, "semantics.lighting_fall: Input should be less than or equal to 2"),
        ({"lighting_fall": -0.1}, "semantics.lighting_fall: Input should be greater than or equal to 0"),
    ],
)
def test_bad_appearance_and_view_parameters_fail_with_one_line(semantics, message):
    with pytest.raises(ConfigError) as err:
        validate_model(FrontEndConfig, {"semantics": semantics}, source="frontend")
    assert message in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_grades_table_bins_cosines_by_appearance_difference():
    """The per-run table: two instances drawn alike sit in the first bin at the same-instance
    cosine; instances drawn apart sit in later bins with lower cosines."""
    from roman_sim.evaluation.grader import FrontEndGrader, GraderPart, _Obs
    from roman_sim.evaluation.grades import GradeConfig, SegmentationGrades

    base = _looks()
    inst = {0: base, 1: base, 2: _looks(lab=(80.0, -10.0, 10.0)), 3: _looks(shape="bush_v1", lab=(20.0, 30.0, -30.0))}
    scene = SceneLooks(inst, {})
    cfg = SemanticConfig()
    obs = []
    for k in range(12):  # 12 frames, each seeing every object from about the same side
        enc = SimulatedEncoder(cfg, seed=4, families=dict.fromkeys(inst, "bush"), robot=f"r{k}", looks=scene)
        for oid in inst:
            desc = enc.encode(None, M, EncodeContext(oid, view_dir=_view(3.0 * k)))
            obs.append(_Obs(oid, "bush", math.radians(3.0 * k), ("a", k), desc))
    grader = FrontEndGrader.from_parts([GraderPart(SegmentationGrades(), obs, len(obs))], cfg=GradeConfig(), seed=0)
    grader.appearance = lambda a, b: cfg.appearance.kernel(inst[a], inst[b])
    d = grader.descriptor_grades()
    assert d.appearance_edges == [0.0, 0.02, 0.1, 0.2, 0.3, 0.5, 1.0]
    by_bin = {d.appearance_edges[k]: st for k, st in enumerate(d.appearance) if st.pairs}
    same = d.sides["same_instance_same_side"]
    # 0 and 1 are drawn alike: 132 cross-frame pairs in the first bin, as alike as one instance
    assert by_bin[0.0].pairs == 12 * 11 and by_bin[0.0].mean == pytest.approx(same.mean, abs=0.01)
    diffs = sorted(1 - cfg.appearance.kernel(inst[a], inst[b]) for a, b in ((0, 2), (0, 3), (2, 3)))
    assert diffs[0] > 0.1 and sum(st.pairs for st in d.appearance) == 6 * 12 * 11  # every pair of instances
    means = [st.mean for st in d.appearance if st.pairs]
    assert means == sorted(means, reverse=True)  # the further apart, the lower the cosine
    text = "\n".join(report_lines_for(d))
    assert "| 0-0.02 | 132 |" in text and "same instance same side" in text


def report_lines_for(d):
    from roman_sim.evaluation.grades import FrontEndGrades, SegmentationGrades
    from roman_sim.report.grades import frontend_report_lines

    return frontend_report_lines(FrontEndGrades("perfect", "simulated", SegmentationGrades(), d))
