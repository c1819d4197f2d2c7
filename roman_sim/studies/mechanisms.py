"""Named heading mechanisms: the ways a robot driving the other way sees a place differently.

Each mechanism says what it changes between opposite views and what "switched off" means
as scenario overrides (``--set`` items, applied by ``roman_sim.core.overrides``), built from
the scenario's raw data (``off(data)``), so a switch fits the scenario it is applied to
(every robot's path, the world's own overrides, the front end's entries). A mechanism that
cannot be switched off in this simulator is registered with the reason (``unavailable``),
so naming it says why instead of "unknown".

The table of the docs (``docs/heading_mechanisms.md``) lists the same entries; the
attribution study (``roman_sim.studies.attribution``) switches them off one at a time.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from roman_sim.core.errors import ConfigError

#: The label of the run with every mechanism on.
ALL_ON = "none"

#: Encoders whose descriptors the ``descriptor_view`` and ``lighting`` switches act on.
_SIMULATED_ENCODERS = ("simulated",)
#: Segmenters with the simulated, view-dependent error model (``view_split_frac``, ``partial_frac``).
_SIMULATED_SEGMENTERS = ("fastsam", "perfect")


@dataclass(frozen=True)
class Mechanism:
    """One heading mechanism.

    Attributes:
        name: registry name.
        acts: what differs between opposite views because of it.
        off: what switching it off means.
        kind: ``switch`` (a model term set to zero), ``counterfactual`` (a physical effect replaced
            by what no camera sees), ``weakened`` (reduced, not removed) or ``unavailable``.
        overrides: ``overrides(data) -> --set items`` switching it off in the scenario ``data``
            (None when ``unavailable``).
        reason: why it cannot be switched off (``unavailable`` only).
    """

    name: str
    acts: str
    off: str
    kind: str
    overrides: Callable[[dict[str, Any]], list[str]] | None
    reason: str = ""


def _robots(data: dict[str, Any]) -> list[dict[str, Any]]:
    robots = data.get("robots")
    return [r for r in robots if isinstance(r, dict)] if isinstance(robots, list) else []


def _entry_name(data: dict[str, Any], key: str, default: str) -> str:
    entry = (data.get("frontend") or {}).get(key, default)
    return entry if isinstance(entry, str) else str((entry or {}).get("name", default))


def _needs_simulated_encoder(name: str, data: dict[str, Any]) -> None:
    enc = _entry_name(data, "encoder", "simulated")
    if enc not in _SIMULATED_ENCODERS:
        raise ConfigError(
            f"mechanisms: {name} switches a term of the simulated descriptors; frontend.encoder {enc!r} has none "
            f"(allowed with: {', '.join(_SIMULATED_ENCODERS)})"
        )


def _descriptor_view(data: dict[str, Any]) -> list[str]:
    _needs_simulated_encoder("descriptor_view", data)
    return ["frontend.semantics.view_dependence=false"]


def _lighting(data: dict[str, Any]) -> list[str]:
    _needs_simulated_encoder("lighting", data)
    return ["frontend.semantics.lighting=false"]


def _simulated_only(name: str, data: dict[str, Any]) -> None:
    if any(r.get("source") is not None for r in _robots(data)):
        raise ConfigError(
            f"mechanisms: {name} is switched off by a counterfactual of the simulator; "
            "a robot read from a sequence cannot honour it (allowed with: simulated robots only)"
        )


def _partial_views(data: dict[str, Any]) -> list[str]:
    _simulated_only("partial_views", data)
    return ["mapping.whole_surface=true"]


def _completion(name: str, reason: str) -> Callable[[dict[str, Any]], list[str]]:
    """The switch that fills in an observation's misses for one reason (``frontend.surface_completion``)."""

    def off(data: dict[str, Any]) -> list[str]:
        _simulated_only(name, data)
        return [f"mapping.complete={json.dumps([reason])}"]

    return off


def _depth_noise(data: dict[str, Any]) -> list[str]:
    return [f"robots.{i}.camera.depth_noise.enabled=false" for i, _ in enumerate(_robots(data))]


def _segmenter_view(data: dict[str, Any]) -> list[str]:
    seg = (data.get("frontend") or {}).get("segmenter", "fastsam")
    name = _entry_name(data, "segmenter", "fastsam")
    if name not in _SIMULATED_SEGMENTERS:
        raise ConfigError(
            f"mechanisms: segmenter_view sets the simulated segmenter's view sectors; frontend.segmenter {name!r} "
            f"has none (allowed with: {', '.join(_SIMULATED_SEGMENTERS)})"
        )
    if isinstance(seg, str):
        return [f"frontend.segmenter={json.dumps({'name': seg, 'params': {'view_split_frac': 0, 'partial_frac': 0}})}"]
    return ["frontend.segmenter.params.view_split_frac=0", "frontend.segmenter.params.partial_frac=0"]


def _road_side(data: dict[str, Any]) -> list[str]:
    out = []
    for i, r in enumerate(_robots(data)):
        path = r.get("path")
        if isinstance(path, dict) and path.get("lateral_offset_m") is not None:
            out.append(f"robots.{i}.path.lateral_offset_m=[0.0, 0.0]")
    return out


#: Field of view and depth range with the mechanism weakened (a pinhole camera cannot see all round).
WIDE_HFOV_DEG = 150.0
WIDE_DEPTH_M = 15.0


def _field_of_view(data: dict[str, Any]) -> list[str]:
    out = []
    for i, _ in enumerate(_robots(data)):
        out += [
            f"robots.{i}.camera.hfov_deg={WIDE_HFOV_DEG:g}",
            f"robots.{i}.camera.vfov_deg=null",
            f"robots.{i}.camera.max_depth_m={WIDE_DEPTH_M:g}",
        ]
    return [*out, f"mapping.max_depth_m={WIDE_DEPTH_M:g}"]


def _sun(data: dict[str, Any]) -> list[str]:
    world = data.get("world") or {}
    ovr = dict(world.get("overrides") or {}) if isinstance(world, dict) else {}
    ovr.update({"appearance.lighting.sun": 0.0, "appearance.lighting.ambient": 0.8})
    out = [f"world.overrides={json.dumps(ovr)}"]
    out += [f"robots.{i}.lighting=null" for i, r in enumerate(_robots(data)) if r.get("lighting") is not None]
    return out


MECHANISMS: dict[str, Mechanism] = {
    m.name: m
    for m in (
        Mechanism(
            "descriptor_view",
            "an instance's simulated descriptor changes with the viewing direction (per family)",
            "frontend.semantics.view_dependence=false: descriptors as if seen from one side",
            "switch",
            _descriptor_view,
        ),
        Mechanism(
            "lighting",
            "the descriptor's light-versus-view term: a face lit from behind the camera or against the sun",
            "frontend.semantics.lighting=false",
            "switch",
            _lighting,
        ),
        Mechanism(
            "partial_views",
            "a segment's centroid, extent and shape come from the side of its object the camera sees",
            "mapping.whole_surface=true: each observation's points from its objects' whole surfaces",
            "counterfactual",
            _partial_views,
        ),
        Mechanism(
            "segmenter_view",
            "the simulated segmenter splits or crops an object from its own sectors of viewing direction",
            "frontend.segmenter.params.view_split_frac=0 and partial_frac=0",
            "switch",
            _segmenter_view,
        ),
        Mechanism(
            "road_side",
            "each robot keeps to its own side of the track (path.lateral_offset_m), so opposite passes "
            "see a roadside object from different distances and sides",
            "every robot on the centre line (lateral_offset_m [0, 0])",
            "switch",
            _road_side,
        ),
        Mechanism(
            "field_of_view",
            "a forward camera sees only what lies ahead within its field of view and depth range",
            f"weakened, not removed: horizontal field of view {WIDE_HFOV_DEG:g} deg (from 87), depth range "
            f"{WIDE_DEPTH_M:g} m (camera and mapping, from 7.5)",
            "weakened",
            _field_of_view,
        ),
        Mechanism(
            "sun",
            "the rendered colour of a face depends on the sun's direction relative to the view",
            "a sun-free world: sun intensity 0, ambient 0.8 (RGB only; robots use the world's lighting)",
            "switch",
            _sun,
        ),
        Mechanism(
            "one_sided_visibility",
            "a camera sees only the faces of an object turned toward it: the other side is seen from the other way",
            "mapping.complete=[back_side]: each observation also gets its objects' faces turned away from the camera",
            "counterfactual",
            _completion("one_sided_visibility", "back_side"),
        ),
        Mechanism(
            "occlusion",
            "which objects hide which parts of others depends on where the camera stands",
            "mapping.complete=[occluded]: an observed object's hidden parts facing the camera are filled in "
            "(which objects are detected still follows the occlusion order)",
            "counterfactual",
            _completion("occlusion", "occluded"),
        ),
        Mechanism(
            "range_truncation",
            "points beyond the depth range are lost, so a long object's far part depends on where it is seen from",
            "mapping.complete=[beyond_range]: an observed object's parts facing the camera beyond the range are "
            "filled in",
            "counterfactual",
            _completion("range_truncation", "beyond_range"),
        ),
        Mechanism(
            "image_edges",
            "an object at the image's edge is cut off there, on the side the camera passes it",
            "mapping.complete=[out_of_view]: an observed object's parts outside the image are filled in",
            "counterfactual",
            _completion("image_edges", "out_of_view"),
        ),
        Mechanism(
            "depth_noise",
            "the depth camera's noise, dropouts and mixed pixels grow with range and grazing angle",
            "every robot's camera.depth_noise.enabled=false",
            "switch",
            _depth_noise,
        ),
    )
}


def switchable() -> list[str]:
    """Names of the mechanisms that can be switched off, in registry order."""
    return [n for n, m in MECHANISMS.items() if m.overrides is not None]


def check_mechanisms(names: Sequence[str], field: str = "mechanisms") -> list[str]:
    """``names`` as given, after checking each is a switchable mechanism (``ConfigError`` naming ``field``)."""
    for n in names:
        if n not in MECHANISMS:
            raise ConfigError(f"{field}: unknown mechanism {n!r} (allowed: {', '.join(switchable())})")
        m = MECHANISMS[n]
        if m.overrides is None:
            raise ConfigError(
                f"{field}: {n} cannot be switched off here: {m.reason} (allowed: {', '.join(switchable())})"
            )
    if len(set(names)) != len(names):
        raise ConfigError(f"{field}: a mechanism is named twice ({', '.join(names)})")
    return list(names)


def mechanism_overrides(name: str, data: dict[str, Any]) -> list[str]:
    """The ``--set`` items that switch mechanism ``name`` off in the raw scenario ``data`` ([] for ``none``)."""
    if name == ALL_ON:
        return []
    check_mechanisms([name])
    fn = MECHANISMS[name].overrides
    assert fn is not None
    return fn(data)
