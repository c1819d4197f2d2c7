"""Front-end presets and severity: named or file-based ``frontend`` sections under a scenario's own.

``frontend.preset`` names a bundled preset (``paper``) or a YAML file holding a ``frontend``
section (what ``roman-sim calibrate`` and the paper fit write). The preset's values come
first and the scenario's own ``frontend`` keys override them (mappings merge key by key; a
segmenter entry of another name replaces the preset's). A file may also hold ``fit`` and
``calibration`` sections (what produced it); they are not read. A file's
``frontend.semantics.dim`` is the dimension of the encoder it was measured on: a scenario
that sets another ``frontend.semantics.dim`` is refused.

``frontend.severity`` (default 1) scales the front end's error parameters when components
are built: the simulated encoder's confusion level (clipped to the largest its means and
spreads allow) and the simulated segmenter's rates in ``SEVERITY_RATES`` (clipped to their
bounds). The configured values stay as written, so a resolved scenario reloads unchanged.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

from roman_sim.core.errors import ConfigError

#: Folder of the bundled front-end presets (package data).
PRESET_DIR = Path(__file__).resolve().parent / "data"
#: Simulated-segmenter rates scaled by ``frontend.severity`` -> their upper bound.
SEVERITY_RATES: dict[str, float] = {
    "oversegment_prob": 1.0,
    "view_split_frac": 1.0,
    "partial_frac": 1.0,
    "undersegment_prob": 1.0,
    "spurious_rate": 20.0,
}
_FILE_KEYS = {"frontend", "fit", "calibration"}


def preset_names() -> list[str]:
    """Names of the bundled presets."""
    return sorted(p.stem for p in PRESET_DIR.glob("*.yaml"))


def preset_path(name_or_path: str) -> Path:
    """The YAML file of a bundled preset name or a path; ``ConfigError`` naming the valid presets."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.is_file():
        if not p.is_file():
            raise ConfigError(f"frontend.preset: {name_or_path}: file not found")
        return p
    bundled = PRESET_DIR / f"{name_or_path}.yaml"
    if not bundled.is_file():
        raise ConfigError(
            f"frontend.preset: unknown preset {name_or_path!r} (valid: {', '.join(preset_names())}, or a YAML file)"
        )
    return bundled


def read_preset(name_or_path: str) -> dict[str, Any]:
    """The ``frontend`` section of a preset (normalised entries; see ``normalise``)."""
    from roman_sim.core.config import read_yaml

    path = preset_path(name_or_path)
    data = read_yaml(path)
    if not isinstance(data, dict) or not isinstance(data.get("frontend"), dict):
        raise ConfigError(f"frontend.preset: {path}: expected a mapping with a 'frontend' section")
    extra = sorted(set(data) - _FILE_KEYS)
    if extra:
        raise ConfigError(f"frontend.preset: {path}: unknown top-level keys {extra} (allowed: {sorted(_FILE_KEYS)})")
    fe = normalise(data["frontend"])
    if "preset" in fe:
        raise ConfigError(f"frontend.preset: {path}: a preset cannot name another preset")
    return fe


def normalise(fe: dict[str, Any]) -> dict[str, Any]:
    """A copy of a ``frontend`` mapping with entries in their long forms (for merging)."""
    out = copy.deepcopy(fe)
    seg = out.get("segmenter")
    if isinstance(seg, str):
        out["segmenter"] = {"name": seg}
    elif isinstance(seg, dict) and seg and not ({"name", "params"} & set(seg)):
        out["segmenter"] = {"name": "fastsam", "params": seg}
    if isinstance(out.get("encoder"), str):
        out["encoder"] = {"name": out["encoder"]}
    sem = out.get("semantics")
    if (
        isinstance(sem, dict)
        and isinstance(sem.get("confusion"), (int, float))
        and not isinstance(sem.get("confusion"), bool)
    ):
        sem["confusion"] = {"level": sem["confusion"]}
    return out


def _merge(base: Any, top: Any) -> Any:
    if isinstance(base, dict) and isinstance(top, dict):
        out = dict(base)
        for k, v in top.items():
            out[k] = _merge(base[k], v) if k in base else copy.deepcopy(v)
        return out
    return copy.deepcopy(top)


def with_preset(fe: dict[str, Any]) -> dict[str, Any]:
    """``fe`` (a scenario's ``frontend`` mapping) over its preset's values; unchanged without a preset."""
    if not isinstance(fe, dict) or fe.get("preset") is None:
        return fe
    name = str(fe["preset"])
    base = read_preset(name)
    own = normalise(fe)
    dim_base = base.get("semantics", {}).get("dim")
    dim_own = own.get("semantics", {}).get("dim") if isinstance(own.get("semantics"), dict) else None
    if dim_base is not None and dim_own is not None and int(dim_base) != int(dim_own):
        raise ConfigError(
            f"frontend.preset: {name} holds semantics measured on a {int(dim_base)}-d encoder, "
            f"but frontend.semantics.dim is {int(dim_own)} (remove one, or calibrate on the {int(dim_own)}-d encoder)"
        )
    seg_base, seg_own = base.get("segmenter"), own.get("segmenter")
    if (
        isinstance(seg_base, dict)
        and isinstance(seg_own, dict)
        and seg_own.get("name", seg_base.get("name")) != seg_base.get("name")
    ):
        base = {k: v for k, v in base.items() if k != "segmenter"}
    return _merge(base, own)


def scaled_segmenter_params(name: str, params: dict[str, Any], severity: float) -> dict[str, Any]:
    """A simulated segmenter's params with ``SEVERITY_RATES`` scaled by ``severity`` (other segmenters: unchanged)."""
    from roman_sim.frontend.segmenter import SEGMENTERS

    if severity == 1.0 or name not in SEGMENTERS:
        return dict(params)
    base = SEGMENTERS.get(name).model_dump()
    base.update(params)
    out = dict(params)
    for field, hi in SEVERITY_RATES.items():
        out[field] = min(hi, float(base[field]) * severity)
    return out
