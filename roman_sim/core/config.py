"""Configuration plumbing: strict pydantic models, YAML loading with one-line errors.

Each stage defines its own model (``WorldSpec``, ``CameraConfig``, ...) by subclassing
``StrictModel``; unknown keys are errors. ``load_model`` and ``validate_model`` turn
pydantic's errors into a ``ConfigError`` whose message names the field and what is allowed.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from roman_sim.core.errors import ConfigError

M = TypeVar("M", bound=BaseModel)


class StrictModel(BaseModel):
    """Base of every configuration model: unknown keys are errors, values are validated."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False)


def format_validation_error(err: ValidationError, source: str = "") -> str:
    """One line naming each bad field and what is allowed."""
    parts = []
    for e in err.errors():
        loc = ".".join(str(x) for x in e["loc"]) or "<root>"
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            msg = "unknown key"
            allowed = _allowed_keys(err, e["loc"])
            if allowed:
                msg += f" (allowed: {', '.join(allowed)})"
        parts.append(f"{loc}: {msg}")
    prefix = f"{source}: " if source else ""
    return prefix + "; ".join(parts)


def _allowed_keys(err: ValidationError, loc: tuple[Any, ...]) -> list[str]:
    model = getattr(err, "_roman_model", None)
    if model is None:
        return []
    cls: Any = model
    for key in loc[:-1]:
        field = getattr(cls, "model_fields", {}).get(key)
        if field is None:
            return []
        cls = field.annotation
        if not (isinstance(cls, type) and issubclass(cls, BaseModel)):
            return []
    return sorted(getattr(cls, "model_fields", {}).keys())


def validate_model(model: type[M], data: Any, source: str = "") -> M:
    """Validate ``data`` into ``model``; raise ``ConfigError`` with a one-line message."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{source or model.__name__}: expected a mapping, got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        err._roman_model = model  # type: ignore[attr-defined]
        raise ConfigError(format_validation_error(err, source or model.__name__)) from None


def read_yaml(path: str | Path) -> Any:
    """Read a YAML file; missing or malformed files raise ``ConfigError``."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: file not found")
    try:
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ConfigError(f"{path}: malformed YAML{where}: {problem}") from None
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{path}: cannot read: {err}") from None


def load_model(model: type[M], path: str | Path) -> M:
    """Load a YAML file into ``model`` (strict)."""
    return validate_model(model, read_yaml(path), source=str(path))


def dump_yaml(model: BaseModel) -> str:
    """The resolved configuration as YAML (stable key order)."""
    return yaml.safe_dump(model.model_dump(mode="json"), sort_keys=False)


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """Apply ``key.sub=value`` overrides (values parsed as YAML) to a nested dict copy."""
    import copy

    out = copy.deepcopy(data)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(f"--set {item!r}: expected key=value")
        key, raw = item.split("=", 1)
        try:
            value = yaml.safe_load(raw)
        except yaml.YAMLError:
            raise ConfigError(f"--set {key}: value {raw!r} is not valid YAML") from None
        node = out
        parts = key.strip().split(".")
        for p in parts[:-1]:
            if isinstance(node, list) and p.isdigit() and int(p) < len(node):
                node = node[int(p)]
                continue
            if not isinstance(node, dict):
                raise ConfigError(f"--set {key}: {p!r} is not a mapping")
            node = node.setdefault(p, {})
        last = parts[-1]
        if isinstance(node, list) and last.isdigit() and int(last) < len(node):
            node[int(last)] = value
        elif isinstance(node, dict):
            node[last] = value
        else:
            raise ConfigError(f"--set {key}: cannot set inside a {type(node).__name__}")
    return out


def stable_hash(*parts: Any) -> str:
    """16 hex digits of SHA-256 over the JSON of ``parts`` (sorted keys; same input -> same hash)."""
    blob = json.dumps(parts, sort_keys=True, default=str).encode("utf-8")
    return hashlib.sha256(blob).hexdigest()[:16]
