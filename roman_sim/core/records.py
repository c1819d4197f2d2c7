"""Typed JSON records: a dataclass to JSON and back, every field checked against its type hint.

A result file is a dataclass on both sides of the disk: ``write_record`` turns it into JSON
(nested dataclasses, mappings, lists and tuples; sorted keys, written atomically) and
``read_record`` reads it back into the same dataclass, checking each field's presence and
type, so a damaged or foreign file fails with one line that names the file and the field:
``leaderboard.json: field levels[0].knob: expected a number, got 'high'``.

Supported field types: ``int``, ``float`` (an integer is kept as written, so the bytes
written back are the same), ``str``, ``bool``, ``None``, unions (``X | None``),
``Literal``, ``list[X]``, ``tuple[X, ...]``, ``tuple[X, Y]``, ``dict[str, X]`` /
``Mapping[str, X]``, nested dataclasses, ``TypedDict`` (read back as a dict, its required keys
present), and ``Any`` or the JSON value aliases (taken as they are). A field with a default
may be absent (files written before it existed); a field whose metadata has ``omit_none``
is left out of the JSON when it is None. Unknown fields are errors.
"""

from __future__ import annotations

import dataclasses
import json
import types
import typing
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSON, JSONLike

T = TypeVar("T")

#: Field metadata: leave the field out of the JSON when it is None (and read it as None when absent).
OMIT_NONE = {"omit_none": True}

__all__ = [
    "OMIT_NONE",
    "RecordError",
    "from_json",
    "read_json",
    "read_record",
    "to_json",
    "to_json_record",
    "write_record",
]


class RecordError(StorageError):
    """A JSON record that does not match its dataclass: names the file and the field."""


class _Mismatch(Exception):
    """A value that does not match its type (``where`` is the field path, ``what`` the problem)."""

    def __init__(self, where: str, what: str) -> None:
        super().__init__(f"field {where}: {what}" if where else what)


def to_json(obj: Any) -> JSON:
    """``obj`` as JSON values: dataclasses as objects (field order), tuples as lists."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: dict[str, JSON] = {}
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if v is None and f.metadata.get("omit_none"):
                continue
            out[f.name] = to_json(v)
        return out
    if isinstance(obj, Mapping):
        return {str(k): to_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_json(v) for v in obj]
    if obj is None or isinstance(obj, (str, int, float, bool)):
        return obj
    raise TypeError(f"not a JSON record value: {type(obj).__name__}")


def from_json(cls: type[T], data: Any, source: str, schema: str | None = None) -> T:
    """``data`` (JSON values) as a ``cls`` dataclass (its ``schema`` field must be ``schema`` when given).

    Raises:
        RecordError: ``<source>: field <path>: <problem>`` for the first field that is
            missing, unknown or of another type, or a schema that is not ``schema``.
    """
    if schema is not None:
        if not isinstance(data, dict):
            raise RecordError(f"{source}: expected a JSON object, got {_kind(data)}")
        data = dict(data)
        got = data.pop("schema", None)
        if got != schema:
            raise RecordError(f"{source}: field schema: expected {schema!r}, got {got!r}")
    try:
        return typing.cast(T, _decode(cls, data, ""))
    except _Mismatch as err:
        raise RecordError(f"{source}: {err}") from None


def read_json(path: str | Path) -> Any:
    """The JSON document in the file ``path``, parsed but not checked (``read_record`` checks it).

    Raises:
        RecordError: the file is missing, unreadable or not JSON (the message names the file).
    """
    path = Path(path)
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise RecordError(f"{path}: cannot read ({err.strerror or type(err).__name__})") from None
    except UnicodeDecodeError:
        raise RecordError(f"{path}: not a JSON file (not UTF-8 text)") from None
    except json.JSONDecodeError as err:
        raise RecordError(f"{path}: not valid JSON (line {err.lineno}: {err.msg})") from None


def read_record(path: str | Path, cls: type[T], schema: str | None = None) -> T:
    """The ``cls`` record in the JSON file ``path`` (its ``schema`` field must be ``schema`` when given).

    Raises:
        RecordError: the file is missing, unreadable, not JSON, of another schema, or a field
            is missing or of another type (the message names the file and the field).
    """
    return from_json(cls, read_json(path), str(path), schema)


def to_json_record(obj: Any, schema: str | None = None) -> JSON:
    """``to_json(obj)`` with a ``schema`` field first when given (``obj`` then a dataclass or mapping)."""
    data = to_json(obj)
    if schema is None:
        return data
    if not isinstance(data, dict):
        raise TypeError("a record with a schema must be a dataclass or a mapping")
    return {"schema": schema, **data}


def write_record(path: str | Path, obj: Any, schema: str | None = None, indent: int | None = 2) -> Path:
    """Atomically write the dataclass ``obj`` as JSON (with a ``schema`` field when given); returns ``path``.

    ``indent=None`` writes it on one line (sorted keys either way).
    """
    write_json(path, to_json_record(obj, schema), indent=indent)
    return Path(path)


def _kind(v: Any) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return f"a boolean ({str(v).lower()})"
    if isinstance(v, (int, float)):
        return f"a number ({v!r})"
    if isinstance(v, str):
        return f"a string ({v!r:.60})"
    if isinstance(v, list):
        return "a list"
    if isinstance(v, dict):
        return "an object"
    return type(v).__name__


def _expected(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if tp is type(None) or tp is None:
        return "null"
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_expected(a) for a in typing.get_args(tp))
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in typing.get_args(tp))
    names = {int: "an integer", float: "a number", str: "a string", bool: "a boolean"}
    if tp in names:
        return names[tp]
    if origin in (list, tuple, Sequence):
        return "a list"
    if origin in (dict, Mapping) or dataclasses.is_dataclass(tp) or typing.is_typeddict(tp):
        return "an object"
    return str(tp)


def _decode(tp: Any, v: Any, where: str) -> Any:
    """``v`` checked against (and built as) ``tp``; raises ``_Mismatch`` naming ``where``."""
    if tp is Any or _is_json_alias(tp):
        return v
    if typing.is_typeddict(tp):
        return _decode_typeddict(tp, v, where)
    if tp is type(None) or tp is None:
        if v is None:
            return None
        raise _Mismatch(where, f"expected null, got {_kind(v)}")
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if v is None and type(None) in args:
            return None
        for a in args:
            if a is type(None):
                continue
            try:
                return _decode(a, v, where)
            except _Mismatch:
                if len([x for x in args if x is not type(None)]) == 1:
                    raise
        raise _Mismatch(where, f"expected {_expected(tp)}, got {_kind(v)}")
    if origin is typing.Literal:
        if v in args and type(v) in {type(a) for a in args}:
            return v
        raise _Mismatch(where, f"expected {_expected(tp)}, got {_kind(v)}")
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        return _decode_dataclass(tp, v, where)
    if origin in (list, Sequence) or tp in (list,):
        if not isinstance(v, list):
            raise _Mismatch(where, f"expected a list, got {_kind(v)}")
        item = args[0] if args else Any
        return [_decode(item, x, f"{where}[{i}]") for i, x in enumerate(v)]
    if origin is tuple:
        return _decode_tuple(args, v, where)
    if origin in (dict, Mapping) or tp in (dict,):
        if not isinstance(v, dict):
            raise _Mismatch(where, f"expected an object, got {_kind(v)}")
        val = args[1] if len(args) == 2 else Any
        return {k: _decode(val, x, f"{where}.{k}" if where else k) for k, x in v.items()}
    return _decode_scalar(tp, v, where)


def _is_json_alias(tp: Any) -> bool:
    """Whether ``tp`` is a JSON value alias, or its recursive reference inside one: any JSON value passes."""
    if isinstance(tp, typing.ForwardRef):
        return tp.__forward_arg__ in ("JSON", "JSONLike")
    return tp is JSON or tp is JSONLike


def _decode_typeddict(tp: Any, v: Any, where: str) -> dict[str, Any]:
    """A ``TypedDict``: its required keys present, no unknown key, every value of its key's type."""
    if not isinstance(v, dict):
        raise _Mismatch(where, f"expected an object, got {_kind(v)}")
    hints = typing.get_type_hints(tp)
    unknown = [k for k in v if k not in hints]
    if unknown:
        name = f"{where}.{unknown[0]}" if where else unknown[0]
        raise _Mismatch(name, f"unknown (valid: {', '.join(hints)})")
    for k in tp.__required_keys__:
        if k not in v:
            raise _Mismatch(f"{where}.{k}" if where else k, "missing")
    return {k: _decode(hints[k], x, f"{where}.{k}" if where else k) for k, x in v.items()}


def _decode_tuple(args: tuple[Any, ...], v: Any, where: str) -> tuple[Any, ...]:
    if not isinstance(v, list):
        raise _Mismatch(where, f"expected a list, got {_kind(v)}")
    if len(args) == 2 and args[1] is Ellipsis:
        return tuple(_decode(args[0], x, f"{where}[{i}]") for i, x in enumerate(v))
    if len(v) != len(args):
        raise _Mismatch(where, f"expected a list of {len(args)} values, got {len(v)}")
    return tuple(_decode(a, x, f"{where}[{i}]") for i, (a, x) in enumerate(zip(args, v)))


def _decode_scalar(tp: Any, v: Any, where: str) -> Any:
    ok = {
        bool: isinstance(v, bool),
        int: isinstance(v, int) and not isinstance(v, bool),
        float: isinstance(v, (int, float)) and not isinstance(v, bool),
        str: isinstance(v, str),
    }
    if tp not in ok:
        raise TypeError(f"{where}: unsupported field type {tp!r} in a JSON record")
    if not ok[tp]:
        raise _Mismatch(where, f"expected {_expected(tp)}, got {_kind(v)}")
    return v


def _decode_dataclass(cls: type, v: Any, where: str) -> Any:
    if not isinstance(v, dict):
        raise _Mismatch(where, f"expected an object, got {_kind(v)}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = [k for k in v if k not in fields]
    if unknown:
        name = f"{where}.{unknown[0]}" if where else unknown[0]
        raise _Mismatch(name, f"unknown (valid: {', '.join(fields)})")
    values: dict[str, Any] = {}
    for name, f in fields.items():
        path = f"{where}.{name}" if where else name
        if name not in v:
            if f.metadata.get("omit_none"):
                values[name] = None
                continue
            if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING:
                continue
            raise _Mismatch(path, "missing")
        values[name] = _decode(hints[name], v[name], path)
    return cls(**values)
