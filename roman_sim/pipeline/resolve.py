"""A scenario's components resolved: every aligner's, segmenter's and encoder's parameters with their defaults.

A scenario names components with the parameters the user set (often none). A run writes
and hashes them resolved instead (``resolve_scenario``), so ``config.yaml`` records the
values the run used and a changed default in the code changes the cache keys of the stages
that run the component:

- a registered aligner: its parameter model (``params_model``, or the ``params`` model of
  the built aligner) with the given values, dumped in full;
- the simulated segmenters (``perfect``, ``fastsam``): their preset's ``SegmenterConfig``
  with the given fields over it (what the segmenter is built from);
- any other registered segmenter or encoder: its ``params_model`` dumped in full;
- a plug-in (``package.module:Class``): its ``params_model`` class attribute (a pydantic
  model) when it has one, else the keyword parameters of its constructor (or factory)
  that have JSON defaults, with the given values over them. Nothing is built;
- a robot's odometry file (``odometry``): the SHA-256 of its bytes (``sha256``), so an
  edited file changes the keys of the maps stage and every stage after it.

Resolving is idempotent: a resolved scenario (a run folder's ``config.yaml``) resolves to
itself. ``component_modules`` names the modules whose code a component runs, the roots of
the stages' code fingerprints (``roman_sim.pipeline.stages.base``).
"""

from __future__ import annotations

import inspect
import json
from typing import TYPE_CHECKING, Any, Literal

from pydantic import BaseModel

from roman_sim.core.config import validate_model
from roman_sim.core.errors import ConfigError, PluginError
from roman_sim.core.registry import import_object

if TYPE_CHECKING:
    from roman_sim.frontend.components import ComponentEntry
    from roman_sim.pipeline.scenario import Scenario

#: The configured components a stage may run.
ComponentKind = Literal["aligners", "segmenter", "encoder"]


def _is_plugin(name: str) -> bool:
    return ":" in name


def _json_value(v: object) -> bool:
    try:
        json.dumps(v, allow_nan=False)
    except (TypeError, ValueError):
        return False
    return True


def plugin_params(path: str, kind: str, params: dict[str, Any]) -> dict[str, Any]:
    """A plug-in's declared parameters with ``params`` over them (see the module docstring); nothing is built."""
    try:
        obj = import_object(path, kind)
    except ConfigError as err:  # as the plug-in checks report it
        raise PluginError(str(err), path, kind) from None
    model = getattr(obj, "params_model", None)
    if isinstance(model, type) and issubclass(model, BaseModel):
        dumped: dict[str, Any] = validate_model(model, params, source=f"{kind} {path!r} params").model_dump(mode="json")
        return dumped
    if not callable(obj):  # an instance takes no parameters
        return dict(params)
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):  # a builtin without a signature
        return dict(params)
    defaults = {
        n: p.default
        for n, p in sig.parameters.items()
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) and p.default is not p.empty and _json_value(p.default)
    }
    return {**defaults, **params}


def aligner_params(method: str, params: dict[str, Any]) -> dict[str, Any]:
    """The resolved parameters of the aligner ``method`` given ``params``."""
    if _is_plugin(method):
        return plugin_params(method, "aligner", params)
    from roman_sim.align import ALIGNERS, build_aligner

    model = getattr(ALIGNERS.get(method), "params_model", None)
    if isinstance(model, type) and issubclass(model, BaseModel):
        dumped: dict[str, Any] = validate_model(model, params, source=f"aligner {method}").model_dump(mode="json")
        return dumped
    built = getattr(build_aligner(method, params), "params", None)
    return built.model_dump(mode="json") if isinstance(built, BaseModel) else dict(params)


def frontend_params(kind: Literal["segmenter", "encoder"], entry: ComponentEntry) -> dict[str, Any]:
    """The resolved parameters of the front end's ``segmenter`` or ``encoder`` entry."""
    from roman_sim.frontend.components import encoder_spec, segmenter_spec
    from roman_sim.frontend.segmenter import SEGMENTERS

    if _is_plugin(entry.name):
        return plugin_params(entry.name, kind, dict(entry.params))
    spec = segmenter_spec(entry) if kind == "segmenter" else encoder_spec(entry)
    given = validate_model(spec.params_model, entry.params, source=f"frontend.{kind}.params")
    if kind == "segmenter" and entry.name in SEGMENTERS:  # a simulated segmenter: its preset under the given fields
        base: dict[str, Any] = SEGMENTERS.get(entry.name).model_dump(mode="json")
        full = given.model_dump(mode="json")
        return {**base, **{k: full[k] for k in given.model_fields_set}}
    dumped: dict[str, Any] = given.model_dump(mode="json")
    return dumped


def resolve_scenario(sc: Scenario) -> Scenario:
    """``sc`` with every aligner's, segmenter's and encoder's parameters resolved (validated again)."""
    from roman_sim.pipeline.scenario import Scenario

    data = sc.model_dump(mode="json")
    for entry, out in zip(sc.aligners, data["aligners"]):
        out["params"] = aligner_params(entry.method, dict(entry.params))
    fe = data["frontend"]
    fe["segmenter"]["params"] = frontend_params("segmenter", sc.frontend.segmenter)
    fe["encoder"]["params"] = frontend_params("encoder", sc.frontend.encoder)
    for robot, out in zip(sc.robots, data["robots"]):
        if robot.odometry is not None:  # the file's content reaches the keys of the stages that read it
            out["odometry"]["sha256"] = robot.odometry.digest()
    return validate_model(Scenario, data, source="resolved scenario")


def aligner_modules(method: str) -> list[str]:
    """The module whose code the aligner ``method`` runs (a plug-in: its own module); none when unknown."""
    if _is_plugin(method):
        return [method.split(":", 1)[0]]
    from roman_sim.align import ALIGNERS

    module = str(getattr(ALIGNERS.get(method), "__module__", ""))
    return [module] if module else []


def component_modules(sc: Scenario, kind: ComponentKind) -> list[str]:
    """The modules whose code the configured components of ``kind`` run (a plug-in: its own module)."""
    if kind == "aligners":
        return sorted({m for a in sc.aligners for m in aligner_modules(a.method)})
    from roman_sim.frontend.components import encoder_spec, segmenter_spec

    entry = sc.frontend.segmenter if kind == "segmenter" else sc.frontend.encoder
    if _is_plugin(entry.name):
        return [entry.name.split(":", 1)[0]]
    spec = segmenter_spec(entry) if kind == "segmenter" else encoder_spec(entry)
    return [spec.build.__module__]
