"""Configuration plumbing: strict pydantic models, YAML loading with one-line errors.

Each stage defines its own model (``WorldSpec``, ``CameraConfig``, ...) by subclassing
``StrictModel``: unknown keys are errors, and NaN or infinity in any float field (scalars,
lists, tuples, nested models) is an error naming the field. Free-form fields (``dict[str,
Any]``) use ``FiniteTree`` for the same check. ``load_model`` and ``validate_model`` turn
pydantic's errors into a ``ConfigError`` whose message names the field and what is allowed.
YAML is read with ``StrictLoader`` (``roman_sim.core.yamlio``): a key repeated in one mapping
is an error naming the key and its lines.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Annotated, Any, TypeVar

import yaml
from pydantic import AfterValidator, BaseModel, ConfigDict, ValidationError
from pydantic_core import PydanticCustomError

from roman_sim.core.config_errors import format_validation_error
from roman_sim.core.errors import ConfigError
from roman_sim.core.overrides import apply_overrides
from roman_sim.core.yamlio import StrictLoader, parse_yaml, read_yaml

M = TypeVar("M", bound=BaseModel)

__all__ = [
    "FiniteTree",
    "StrictLoader",
    "StrictModel",
    "apply_overrides",
    "dump_yaml",
    "format_validation_error",
    "load_model",
    "override_model",
    "parse_yaml",
    "read_yaml",
    "stable_hash",
    "validate_model",
]


class StrictModel(BaseModel):
    """Base of every configuration model: unknown keys and non-finite floats are errors."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False, allow_inf_nan=False)


def _finite_tree(value: Any) -> Any:
    bad = _first_non_finite(value, "")
    if bad is not None:
        where, v = bad
        raise PydanticCustomError(
            "non_finite", "must be a finite number (got {value})", {"where": where, "value": repr(v)}
        )
    return value


def _first_non_finite(value: Any, where: str) -> tuple[str, float] | None:
    if isinstance(value, float) and not math.isfinite(value):
        return where, value
    items: Any = ()
    if isinstance(value, dict):
        items = value.items()
    elif isinstance(value, (list, tuple)):
        items = enumerate(value)
    for k, v in items:
        bad = _first_non_finite(v, f"{where}.{k}" if where else str(k))
        if bad is not None:
            return bad
    return None


#: Free-form value (plug-in parameters, override maps) in which every float must be finite.
FiniteTree = Annotated[Any, AfterValidator(_finite_tree)]


def validate_model(model: type[M], data: Any, source: str = "") -> M:
    """Validate ``data`` into ``model``; raise ``ConfigError`` with a one-line message."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{source or model.__name__}: expected a mapping, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise ConfigError(format_validation_error(err, source or model.__name__, model)) from None


def override_model(model: M, overrides: list[str], source: str = "") -> M:
    """``model`` with the ``key=value`` ``overrides`` applied and validated again (ConfigError in one line)."""
    data = apply_overrides(model.model_dump(mode="json"), overrides)
    return validate_model(type(model), data, source or type(model).__name__)


def load_model(model: type[M], path: str | Path) -> M:
    """Load a YAML file into ``model`` (strict)."""
    return validate_model(model, read_yaml(path), source=str(path))


def dump_yaml(model: BaseModel) -> str:
    """The resolved configuration as YAML (stable key order)."""
    return yaml.safe_dump(model.model_dump(mode="json"), sort_keys=False)


def stable_hash(*parts: Any) -> str:
    """16 hex digits of SHA-256 over the JSON of ``parts`` (sorted keys; same input -> same hash)."""
    blob = json.dumps(parts, sort_keys=True, default=str).encode("utf-8")
    return hashlib.sha256(blob).hexdigest()[:16]
