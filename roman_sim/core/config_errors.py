"""One-line messages from pydantic's validation errors: the field, what is wrong, what is allowed.

Locations are walked along the model's annotations, so an unknown key deep inside a list of
models (``robots.0.camera.bogus``) is reported with the keys allowed there, and the member
tags pydantic inserts for union fields (``frontend.segmenter.SegmenterConfig.foo``) are
dropped: when the input was a mapping, only the model member's errors are reported.
"""

from __future__ import annotations

import types
from collections.abc import Mapping, Sequence
from typing import Annotated, TypeGuard, Union, get_args, get_origin

from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails

#: A location inside the validated data: keys and list indices.
Loc = tuple[int | str, ...]

_MAX_GOT = 40  # longest repr of a bad value quoted in a message


def format_validation_error(err: ValidationError, source: str = "", model: type[BaseModel] | None = None) -> str:
    """One line naming each bad field and what is allowed (``model``: the validated class)."""
    model = model or getattr(err, "_roman_model", None)
    entries = [_Entry(e, model) for e in err.errors()]
    entries = _drop_union_alternatives(entries)
    parts: list[str] = []
    for e in entries:
        line = f"{e.path}: {e.message()}"
        if line not in parts:
            parts.append(line)
    prefix = f"{source}: " if source else ""
    return prefix + "; ".join(parts)


class _Entry:
    """One pydantic error with its location cleaned of union tags."""

    def __init__(self, e: ErrorDetails, model: type[BaseModel] | None) -> None:
        self.raw = e
        self.loc, self.union_at, self.depth_below_union, self.parent = _walk(model, tuple(e["loc"]))
        self.alternatives: list[str] = []

    @property
    def path(self) -> str:
        loc = list(self.loc)
        if self.raw["type"] == "non_finite" and self.raw.get("ctx", {}).get("where"):
            loc += str(self.raw["ctx"]["where"]).split(".")
        return ".".join(str(x) for x in loc) or "<root>"

    def message(self) -> str:
        e = self.raw
        kind, msg = e["type"], e["msg"]
        if self.alternatives:
            return f"expected {' or '.join(self.alternatives)}{_got(e.get('input'))}"
        if kind == "extra_forbidden":
            allowed = _fields(self.parent)
            return "unknown key" + (f" (allowed: {', '.join(allowed)})" if allowed else "")
        if kind == "finite_number":
            return f"must be a finite number{_got(e.get('input'))}"
        if kind == "missing":
            return "required"
        if kind == "value_error" and msg.startswith("Value error, "):
            return msg[len("Value error, ") :]
        if kind.startswith(("too_short", "too_long")):
            return msg
        if kind.startswith(
            (
                "greater",
                "less",
                "multiple",
                "string_",
                "int_",
                "float_",
                "bool_",
                "literal",
                "enum",
                "list_",
                "tuple_",
                "dict_",
                "model_",
                "none_",
            )
        ):
            return msg + _got(e.get("input"))
        return msg


def _got(value: object) -> str:
    if isinstance(value, (dict, list, tuple, set)):
        return f" (got a {type(value).__name__})"
    text = repr(value)
    return f" (got {text})" if len(text) <= _MAX_GOT else ""


def _drop_union_alternatives(entries: list[_Entry]) -> list[_Entry]:
    """Per union field: keep the deep errors of the member the input was meant for, else one summary."""
    by_field: dict[Loc, list[_Entry]] = {}
    for e in entries:
        if e.union_at is not None:
            by_field.setdefault(e.union_at, []).append(e)
    out = [e for e in entries if e.union_at is None]
    for group in by_field.values():
        deep = [e for e in group if e.depth_below_union > 0]
        if deep:
            out.extend(deep)
            continue
        first = group[0]
        first.alternatives = [_describe(e.raw) for e in group]
        out.append(first)
    return out


def _describe(e: ErrorDetails) -> str:
    """What one union member accepts, from its type error (``a valid string`` -> ``a string``)."""
    msg: str = e["msg"]
    if e["type"] == "model_type":
        return f"a mapping of {e.get('ctx', {}).get('class_name', 'its')} fields"
    for head in ("Input should be a valid ", "Input should be "):
        if msg.startswith(head):
            rest = msg[len(head) :].split(",")[0]
            return rest if rest.startswith(("a ", "an ", "'")) else f"a {rest}"
    return msg


def _unwrap(ann: object) -> object:
    while get_origin(ann) is Annotated:
        ann = get_args(ann)[0]
    return ann


def _is_model(ann: object) -> TypeGuard[type[BaseModel]]:
    return isinstance(ann, type) and issubclass(ann, BaseModel)


def _tag(member: object) -> str:
    return member.__name__ if isinstance(member, type) else str(member)


def _walk(model: object, loc: Loc) -> tuple[list[int | str], Loc | None, int, object]:
    """(location without union tags, location of the union field or None, depth below it, parent annotation)."""
    clean: list[int | str] = []
    ann: object = model
    union_at: Loc | None = None
    depth, parent = 0, None
    for key in loc:
        ann = _unwrap(ann)
        if get_origin(ann) in (Union, types.UnionType):
            members = [_unwrap(a) for a in get_args(ann) if a is not type(None)]
            match = next((m for m in members if _tag(m) == key), None)
            if match is not None:
                union_at, depth, ann = tuple(clean), 0, match
                continue
            ann = next((m for m in members if _is_model(m)), members[0] if members else None)
        parent = ann
        clean.append(key)
        if union_at is not None:
            depth += 1
        ann = _child(ann, key)
    return clean, union_at, depth, parent


def _child(ann: object, key: int | str) -> object:
    """Annotation of ``ann[key]`` (a field of a model, an item of a list or tuple, a mapping value)."""
    if _is_model(ann):
        field = ann.model_fields.get(key) if isinstance(key, str) else None
        return None if field is None else field.annotation
    origin, args = get_origin(ann), get_args(ann)
    if origin is tuple and args and args[-1] is not Ellipsis:
        return args[key] if isinstance(key, int) and 0 <= key < len(args) else None
    if origin in (list, tuple, set, frozenset, Sequence):
        return args[0] if args else None
    if origin in (dict, Mapping):
        return args[1] if len(args) == 2 else None
    return None


def _fields(ann: object) -> list[str]:
    ann = _unwrap(ann)
    return sorted(ann.model_fields) if _is_model(ann) else []
