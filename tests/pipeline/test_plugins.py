"""User plug-ins: import, construction, protocol, dry call and return type, run-time guards, import path.

Each broken plug-in gives one ``PluginError`` line that names the plug-in and says what is
wrong; working plug-ins (including the bundled examples) pass and are returned built.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from roman_sim.align.base import AlignResult
from roman_sim.align.synthetic import make_submap_pair
from roman_sim.core.errors import ConfigError, PluginError
from roman_sim.mapping import synthetic
from roman_sim.pipeline.plugin_guard import guard_aligner, guard_frontend
from roman_sim.pipeline.plugins import load_plugin

MODULE = "roman_user_plugins_t"
SOURCE = """
import numpy as np
from roman_sim.align.base import AlignResult
from roman_sim.mapping.mask import Mask

class RaisesInInit:
    name = "x"
    def __init__(self):
        raise RuntimeError("no GPU here")
    def align(self, a, b): ...

class NoAlign:
    name = "x"

class NoName:
    def align(self, a, b): ...

def _ret(value):
    class Returns:
        name = "r"
        def align(self, a, b):
            return value
        def segment(self, frame):
            return value
        def encode(self, crop, mask, ctx):
            return value
    return Returns

ReturnsNone, ReturnsDict, ReturnsStr = _ret(None), _ret({"T": 1}), _ret("fine")

class Divides:
    name = "div"
    def align(self, a, b):
        return 1 / 0
    def segment(self, frame):
        return 1 / 0
    def encode(self, crop, mask, ctx):
        return 1 / 0

class NanPose:
    name = "nan"
    def align(self, a, b):
        return AlignResult("nan", np.full((4, 4), np.nan), np.zeros((0, 2), np.int64), np.zeros(0), 0.0)

class OutOfRange:
    name = "oor"
    def align(self, a, b):
        return AlignResult("oor", np.eye(4), np.array([[0, len(b)]]), np.ones(1), 0.0)

class Good:
    name = "good"
    def __init__(self, k=1):
        self.k = k
        self.calls = 0
    def align(self, a, b):
        self.calls += 1
        return AlignResult.failure(self.name, "declines")

class ArraySegmenter:
    def segment(self, frame):
        return [frame.depth > 0]

class WrongShape:
    def segment(self, frame):
        return [Mask(np.ones((3, 3), bool))]

class GoodSegmenter:
    def segment(self, frame):
        return [Mask(frame.depth > 0)]

class NotUnit:
    def encode(self, crop, mask, ctx):
        return np.ones(8)

class NanVector:
    def encode(self, crop, mask, ctx):
        return np.array([np.nan, 1.0])

class NeedsRgb:
    def encode(self, crop, mask, ctx):
        m = crop.reshape(-1, 3).mean(axis=0)
        return m / np.linalg.norm(m)

class GrowingEncoder:
    def __init__(self):
        self.n = 4
    def encode(self, crop, mask, ctx):
        self.n += 1
        return np.ones(self.n) / np.sqrt(self.n)
"""


@pytest.fixture(scope="module")
def plugin_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("plugins")
    (d / f"{MODULE}.py").write_text(SOURCE)
    (d / "plug_syntax.py").write_text("def broken(:\n")
    (d / "plug_raises.py").write_text("raise RuntimeError('boom while importing')\n")
    (d / "plug_missing_dep.py").write_text("import no_such_dependency_xyz\n")
    sys.path.insert(0, str(d))
    yield d
    sys.path.remove(str(d))


def _fails(path: str, kind: str, **kw: object) -> str:
    with pytest.raises(PluginError) as e:
        load_plugin(path, kind, **kw)
    msg = str(e.value)
    assert "\n" not in msg and e.value.plugin == path
    return msg


@pytest.mark.parametrize(
    ("name", "kind", "expect"),
    [
        (
            "plug_syntax:X",
            "aligner",
            "aligner 'plug_syntax:X': importing 'plug_syntax' raised SyntaxError: invalid syntax",
        ),
        ("plug_raises:X", "segmenter", "importing 'plug_raises' raised RuntimeError: boom while importing"),
        ("plug_missing_dep:X", "encoder", "cannot import 'plug_missing_dep': No module named 'no_such_dependency_xyz'"),
        ("no_such_plugin_pkg:X", "aligner", "cannot import 'no_such_plugin_pkg'"),
        (f"{MODULE}:Nope", "aligner", f"{MODULE!r} has no attribute 'Nope'"),
        (MODULE, "aligner", "expected package.module:Name"),
        (f"{MODULE}:RaisesInInit", "aligner", "RaisesInInit() raised RuntimeError: no GPU here"),
        (f"{MODULE}:NoAlign", "aligner", "NoAlign has no method 'align'; an aligner has a 'name' and align(a, b)"),
        (f"{MODULE}:NoName", "aligner", "needs a non-empty string attribute 'name' (got None)"),
        (f"{MODULE}:ReturnsNone", "aligner", "align(a, b) returned None, expected an AlignResult"),
        (f"{MODULE}:ReturnsDict", "aligner", "align(a, b) returned a dict, expected an AlignResult"),
        (f"{MODULE}:ReturnsStr", "aligner", "align(a, b) returned a str ('fine'), expected an AlignResult"),
        (
            f"{MODULE}:Divides",
            "aligner",
            "the check on two synthetic submaps raised ZeroDivisionError: division by zero",
        ),
        (
            f"{MODULE}:NanPose",
            "aligner",
            "AlignResult.T_a_b is a float64 array of shape (4, 4), expected None or a finite",
        ),
        (f"{MODULE}:OutOfRange", "aligner", "associations index segments outside the submaps"),
        (f"{MODULE}:ReturnsNone", "segmenter", "segment(frame) returned None, expected a list of Mask"),
        (f"{MODULE}:ReturnsDict", "segmenter", "segment(frame) returned a dict, expected a list of Mask"),
        (f"{MODULE}:ReturnsStr", "segmenter", "segment(frame) returned a str ('fine'), expected a list of Mask"),
        (f"{MODULE}:ArraySegmenter", "segmenter", "item 0 is a bool array of shape (48, 64), expected a Mask"),
        (
            f"{MODULE}:WrongShape",
            "segmenter",
            "mask 0 is a bool array of shape (3, 3), expected a bool array of the frame's",
        ),
        (f"{MODULE}:Divides", "segmenter", "the check on a synthetic 64 x 48 frame raised ZeroDivisionError"),
        (f"{MODULE}:ReturnsNone", "encoder", "encode(...) returned None, expected a unit float vector"),
        (f"{MODULE}:ReturnsDict", "encoder", "encode(...) returned a dict, expected a unit float vector"),
        (f"{MODULE}:ReturnsStr", "encoder", "encode(...) returned a str ('fine'), expected a unit float vector"),
        (f"{MODULE}:NotUnit", "encoder", "returned a vector of norm 2.828, expected a unit vector"),
        (f"{MODULE}:NanVector", "encoder", "returned a vector with NaN or infinite entries"),
        (f"{MODULE}:Good", "planner", "plug-in kind 'planner' unknown (valid: aligner, segmenter, encoder)"),
    ],
)
def test_broken_plugins_fail_in_one_line(plugin_dir: Path, name: str, kind: str, expect: str) -> None:
    msg = _fails(name, kind)
    assert expect in msg, msg
    if kind != "planner":
        assert msg.startswith(f"{kind} {name!r}: ")


def test_constructor_parameters(plugin_dir: Path) -> None:
    obj = load_plugin(f"{MODULE}:Good", "aligner", {"k": 3})
    assert obj.k == 3 and obj.calls == 1  # built with the parameters, dry-run once
    msg = _fails(f"{MODULE}:Good", "aligner", params={"q": 1})
    assert "Good(**{'q': 1}) raised TypeError" in msg and "unexpected keyword argument 'q'" in msg


def test_rgb_free_runs_are_checked_like_the_run(plugin_dir: Path) -> None:
    load_plugin(f"{MODULE}:NeedsRgb", "encoder")
    msg = _fails(f"{MODULE}:NeedsRgb", "encoder", with_rgb=False)
    assert "raised AttributeError" in msg


@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("examples.mutual_nn_aligner:MutualNNAligner", "aligner"),
        ("roman_sim.examples.depth_segmenter:DepthEdgeSegmenter", "segmenter"),
        ("roman_sim.examples.depth_segmenter:ShapeEncoder", "encoder"),
        (f"{MODULE}:GoodSegmenter", "segmenter"),
    ],
)
def test_working_plugins_pass(plugin_dir: Path, monkeypatch: pytest.MonkeyPatch, name: str, kind: str) -> None:
    monkeypatch.chdir(Path(__file__).resolve().parents[2])  # the repository root: examples/ links the package's
    assert hasattr(load_plugin(name, kind), {"aligner": "align", "segmenter": "segment", "encoder": "encode"}[kind])


def test_build_aligner_reports_plugin_failures_in_one_line(plugin_dir: Path) -> None:
    from roman_sim.align import build_aligner

    with pytest.raises(PluginError, match=r"RaisesInInit\(\) raised RuntimeError: no GPU here"):
        build_aligner(f"{MODULE}:RaisesInInit")
    with pytest.raises(PluginError, match="importing 'plug_syntax' raised SyntaxError"):
        build_aligner("plug_syntax:X")
    with pytest.raises(ConfigError, match="unknown aligner 'nope'"):
        build_aligner("nope")


def test_guarded_aligner_names_the_pair(plugin_dir: Path) -> None:
    from roman_user_plugins_t import Divides, Good, ReturnsDict  # type: ignore[import-not-found]

    a, b, _ = make_submap_pair(seed=1, n_inliers=5, n_outliers_a=1, n_outliers_b=1)
    path = f"{MODULE}:Divides"
    with pytest.raises(PluginError) as e:
        guard_aligner(Divides(), path).align(a, b)
    assert str(e.value) == f"aligner {path!r} failed on pair a/0 - b/0: ZeroDivisionError: division by zero"
    with pytest.raises(PluginError, match=r"on pair a/0 - b/0: align\(a, b\) returned a dict"):
        guard_aligner(ReturnsDict(), "m:ReturnsDict").align(a, b)
    good = Good()
    assert guard_aligner(good, "roman") is good  # built-in names are not wrapped
    assert guard_aligner(good, "m:Good").align(a, b).reason == "declines"


def test_guarded_frontend_names_the_frame(plugin_dir: Path) -> None:
    from roman_user_plugins_t import Divides, GrowingEncoder  # type: ignore[import-not-found]

    from roman_sim.frontend.segmenter import simulated_segmenter
    from roman_sim.mapping.mapper import Mapper
    from roman_sim.mapping.tracker import MappingConfig

    frames = synthetic.drive(synthetic.sphere_field(4, seed=0), n=1)  # 160 x 120: three observations
    seg, enc = guard_frontend(simulated_segmenter("perfect"), "perfect", Divides(), "m:Divides")
    with pytest.raises(PluginError) as e:
        Mapper(MappingConfig(), seg, enc).process(frames[0])
    assert str(e.value) == (
        "encoder 'm:Divides' failed on a mask of frame 0 of robot a: ZeroDivisionError: division by zero"
    )
    seg, enc = guard_frontend(Divides(), "m:Divides", None, "simulated")
    with pytest.raises(PluginError, match="segmenter 'm:Divides' failed on frame 0 of robot a: ZeroDivisionError"):
        Mapper(MappingConfig(), seg, enc).process(frames[0])
    seg, enc = guard_frontend(simulated_segmenter("perfect"), "perfect", GrowingEncoder(), "m:Growing")
    with pytest.raises(
        PluginError, match="on a mask of frame 0 of robot a: encode.* returned 6 values, earlier descriptors had 5"
    ):
        Mapper(MappingConfig(), seg, enc).process(frames[0])


def test_module_resolves_from_the_current_folder(tmp_path: Path) -> None:
    """``module:Class`` works from the folder holding the module, without PYTHONPATH or '' on sys.path."""
    (tmp_path / "my_local_plugin.py").write_text(
        textwrap.dedent("""
        from roman_sim.align.base import AlignResult
        class Local:
            name = "local"
            def align(self, a, b):
                return AlignResult.failure("local", "no")
    """)
    )
    code = (
        "import sys; from roman_sim.pipeline.plugins import load_plugin; "
        "assert '' not in sys.path; print(type(load_plugin('my_local_plugin:Local', 'aligner')).__name__)"
    )
    env = {"PYTHONPATH": str(Path(__file__).resolve().parents[2]), "PATH": "", "MUJOCO_GL": "egl"}
    out = subprocess.run([sys.executable, "-P", "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "Local"


def test_dry_inputs_are_small_and_public() -> None:
    from roman_sim.pipeline.plugins import _dry_frame, _dry_submaps

    a, b = _dry_submaps(16)
    assert a.truth is None and b.truth is None and a.descriptors.shape[1] == 16
    frame, mask, crop, ctx = _dry_frame(True)
    assert frame.depth.shape == (48, 64) and frame.rgb.shape == (48, 64, 3)
    assert mask.any() and crop.shape[:2] == mask.shape and ctx.object_id is not None
    assert np.asarray(frame.truth.object_ids)[frame.truth.object_ids >= 0].size > 0
    assert isinstance(AlignResult.failure("x", "y"), AlignResult)
