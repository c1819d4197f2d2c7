"""Strict configuration loading, overrides, registry and atomic writes."""

import json

import numpy as np
import pytest
from pydantic import Field

from roman_sim.core import atomic
from roman_sim.core.config import StrictModel, apply_overrides, load_model, validate_model
from roman_sim.core.errors import ConfigError, StorageError
from roman_sim.core.geometry import make_T, rpy_to_R
from roman_sim.core.registry import Registry, import_object
from roman_sim.core.seeding import child_rng
from roman_sim.core.trajectory import Trajectory
from roman_sim.core.tum import read_tum, write_tum


class Inner(StrictModel):
    sigma: float = Field(0.4, gt=0)


class Outer(StrictModel):
    name: str = "x"
    inner: Inner = Inner()


def test_unknown_key_names_field_and_allowed(tmp_path):
    with pytest.raises(ConfigError) as e:
        validate_model(Outer, {"inner": {"sigmaa": 1}})
    msg = str(e.value)
    assert "inner.sigmaa" in msg and "unknown key" in msg and "sigma" in msg


def test_out_of_range_names_field():
    with pytest.raises(ConfigError, match=r"inner\.sigma: .*greater than 0"):
        validate_model(Outer, {"inner": {"sigma": -1}})


def test_malformed_and_missing_yaml(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    with pytest.raises(ConfigError, match="malformed YAML"):
        load_model(Outer, bad)
    with pytest.raises(ConfigError, match="file not found"):
        load_model(Outer, tmp_path / "nope.yaml")
    lst = tmp_path / "list.yaml"
    lst.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="expected a mapping"):
        load_model(Outer, lst)


def test_overrides_nested_and_lists():
    data = {"a": {"b": 1}, "robots": [{"speed": 1.0}, {"speed": 2.0}]}
    out = apply_overrides(data, ["a.b=3", "robots.1.speed=0.5", "c.d=[1, 2]"])
    assert out == {"a": {"b": 3}, "robots": [{"speed": 1.0}, {"speed": 0.5}], "c": {"d": [1, 2]}}
    assert data["a"]["b"] == 1  # input untouched
    with pytest.raises(ConfigError, match="key=value"):
        apply_overrides(data, ["novalue"])


def test_registry_lists_valid_names_and_imports():
    reg: Registry[int] = Registry("thing")
    reg.register("one", 1)
    assert reg.get("one") == 1
    with pytest.raises(ConfigError, match="unknown thing 'two' \\(valid: one"):
        reg.get("two")
    assert reg.get("json:dumps") is json.dumps
    with pytest.raises(ConfigError, match="cannot import"):
        import_object("no_such_pkg_xyz:Foo")
    with pytest.raises(ConfigError, match="has no attribute"):
        import_object("json:nope")


def test_child_rng_is_stable_and_independent():
    a1 = child_rng(7, "drift", "r0").random(4)
    a2 = child_rng(7, "drift", "r0").random(4)
    b = child_rng(7, "drift", "r1").random(4)
    c = child_rng(8, "drift", "r0").random(4)
    assert np.array_equal(a1, a2)
    assert not np.allclose(a1, b) and not np.allclose(a1, c)


def test_atomic_write_leaves_no_partial_file(tmp_path):
    target = tmp_path / "out.json"
    atomic.write_json(target, {"b": 1, "a": np.float64(2.0)})
    assert json.loads(target.read_text()) == {"a": 2.0, "b": 1}
    with pytest.raises(RuntimeError):
        with atomic.atomic_open(target, "wb") as fh:
            fh.write(b"half")
            raise RuntimeError("interrupted")
    assert json.loads(target.read_text()) == {"a": 2.0, "b": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_tum_round_trip_and_errors(tmp_path):
    T = np.stack([make_T(rpy_to_R(0.1 * k, -0.2, k), [k, 2, 3]) for k in range(4)])
    write_tum(tmp_path / "a.tum", Trajectory(np.arange(4) / 6, T))
    back = read_tum(tmp_path / "a.tum")
    assert np.allclose(back.t, np.arange(4) / 6) and np.allclose(T, back.T, atol=1e-8)
    (tmp_path / "nan.tum").write_text("0 nan 0 0 0 0 0 1\n")
    with pytest.raises(StorageError, match=r"nan.tum:1: field tx: nan is not a finite number"):
        read_tum(tmp_path / "nan.tum")
    (tmp_path / "back.tum").write_text("1 0 0 0 0 0 0 1\n0 0 0 0 0 0 0 1\n")
    with pytest.raises(StorageError, match="backwards"):
        read_tum(tmp_path / "back.tum")
    (tmp_path / "bad.tum").write_text("0 1 2\n")
    with pytest.raises(StorageError, match="expected 8 values"):
        read_tum(tmp_path / "bad.tum")
    with pytest.raises(StorageError, match="not found"):
        read_tum(tmp_path / "missing.tum")
