"""``key.sub=value`` overrides of nested configuration data (``--set`` on the command line).

Dotted parts index mappings by key and lists by position (``robots.1.drift=poor``); the
value is parsed as YAML (strictly: a repeated key is an error). A missing mapping key is
created (the model's validation then names it if it is unknown); a list position out of
range, a non-numeric position or a path through a scalar is a ``ConfigError`` that says so,
naming the override as the user wrote it (``--set robots.1.drift`` on the command line,
``world.overrides (tiny): families.9.density`` in a scenario file: see ``source``).

``@file.yaml`` in place of ``key=value`` applies a YAML file of scenario sections (as
``roman-sim tune`` writes them): its mappings are walked into dotted keys, anything else (a
list, a scalar) is the value of its key, so ``aligners: [...]`` replaces the aligners and
``gating: {top_k: 4}`` sets ``gating.top_k`` only.
"""

from __future__ import annotations

import copy
from typing import Any

from roman_sim.core.errors import ConfigError
from roman_sim.core.yamlio import parse_yaml


def apply_overrides(data: dict[str, Any], overrides: list[str], source: str = "--set") -> dict[str, Any]:
    """Apply ``key.sub=value`` overrides (values parsed as YAML) to a nested copy of ``data``.

    ``source`` says where the overrides come from in error messages: ``--set`` (``--set
    a.b: ...``) or a field of a file (``world.overrides (tiny)`` gives ``world.overrides
    (tiny): a.b: ...``).
    """
    out = copy.deepcopy(data)
    for key, value, label in _expand(overrides, source):
        parts = key.split(".")
        node: Any = out
        for depth, part in enumerate(parts):
            last = depth == len(parts) - 1
            here = ".".join(parts[:depth]) or "<root>"
            if isinstance(node, list):
                idx = _index(label, here, part, node)
                if last:
                    node[idx] = value
                else:
                    node = node[idx]
            elif isinstance(node, dict):
                if last:
                    node[part] = value
                else:
                    node = node.setdefault(part, {})
            else:
                raise ConfigError(
                    f"{label}: {here} is {_kind(node)} ({node!r}), not a mapping or list, so it has no {part!r}"
                )
    return out


def _expand(overrides: list[str], source: str) -> list[tuple[str, Any, str]]:
    """(key, value, label) of each override; an ``@file.yaml`` gives one per leaf of its sections."""
    out = []
    for item in overrides:
        if item.startswith("@"):
            out += [(k, v, _label(f"{source} {item}", k)) for k, v in _file_items(item[1:], f"{source} {item}")]
        else:
            key, value = _parse(item, source)
            out.append((key, value, _label(source, key)))
    return out


def _file_items(path: str, label: str) -> list[tuple[str, Any]]:
    """The dotted (key, value) leaves of a YAML file of sections."""
    from pathlib import Path

    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"{label}: cannot read the file ({type(err).__name__})") from None
    data = parse_yaml(text, label)
    if not isinstance(data, dict) or not data:
        raise ConfigError(f"{label}: expected a mapping of scenario sections")
    items: list[tuple[str, Any]] = []

    def walk(prefix: str, node: Any) -> None:
        if isinstance(node, dict) and node:
            for k, v in node.items():
                walk(f"{prefix}.{k}" if prefix else str(k), v)
        else:
            items.append((prefix, node))

    walk("", data)
    return items


def _label(source: str, key: str) -> str:
    """How an override is named in messages: ``--set a.b`` or ``world.overrides (tiny): a.b``."""
    return f"{source} {key}" if source.startswith("-") else f"{source}: {key}"


def _parse(item: str, source: str) -> tuple[str, Any]:
    if "=" not in item:
        raise ConfigError(f"{_label(source, repr(item))}: expected key=value")
    key, raw = item.split("=", 1)
    key = key.strip()
    if not key or any(not p for p in key.split(".")):
        raise ConfigError(f"{_label(source, repr(item))}: empty key or empty part in {key!r} (use a.b.c=value)")
    return key, parse_yaml(raw, f"{_label(source, key)}: value {raw!r}")


def _index(label: str, here: str, part: str, node: list[Any]) -> int:
    n = len(node)
    valid = f"0..{n - 1}" if n else "none: the list is empty"
    if not part.isdigit():
        raise ConfigError(
            f"{label}: {here} is a list of {n} entries, {part!r} is not a position in it (positions: {valid})"
        )
    idx = int(part)
    if idx >= n:
        raise ConfigError(f"{label}: position {idx} out of range: {here} has {n} entries (positions: {valid})")
    return idx


def _kind(value: Any) -> str:
    if value is None:
        return "empty"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    return "a string" if isinstance(value, str) else f"a {type(value).__name__}"
