"""Typed JSON records: a dataclass to JSON and back, every field checked against its type hint.

A result file is a dataclass on both sides of the disk: ``write_record`` turns it into JSON
(nested dataclasses, mappings, lists and tuples; sorted keys, written atomically) and
``read_record`` reads it back into the same dataclass, checking each field's presence and
type, so a damaged or foreign file fails with one line that names the file and the field:
``leaderboard.json: field levels[0].knob: expected a number, got 'high'``.

Supported field types: ``int``, ``float`` (an integer is kept as written, so the bytes
written back are the same), ``str``, ``bool``, ``None``, unions (``X | None``),
``Literal``, ``list[X]``, ``tuple[X, ...]``, ``tuple[X, Y]``, ``dict[str, X]`` /
``Mapping[str, X]`` (with ``Literal`` keys: only those), nested dataclasses, ``TypedDict`` (read
back as a dict, its required keys present), pydantic models (``model_dump(mode="json")``; their
validation errors name the field), and ``Any`` or the JSON value aliases (taken as they are). A
field with a default may be absent (files written before it existed). Unknown fields are errors.

Field metadata shapes the JSON where a file's layout is older than its dataclass:

- ``OMIT_NONE``: left out when None (and read as None when absent);
- ``OMIT_EMPTY``: left out when empty (an empty mapping or list; read as its default when absent);
- ``NONE_AS_EMPTY``: None written as ``{}`` (and ``{}`` read as None);
- ``INLINE``: a nested dataclass whose fields, or a ``dict[str, X]`` whose entries, are written
  at the level of the field's own dataclass (an inline mapping takes the keys no field claims);
- ``json_key(key)``: the field's JSON key when it is not a Python name (``cross-robot``);
- ``via(json_type, encode, decode)``: the value is written as ``encode(value)``, a ``json_type``,
  and read back as ``decode`` of the ``json_type`` read (numpy arrays, derived figures).

Documents inside other files (an ``.npz`` header, a PNG text chunk) use ``dumps_record`` and
``loads_record`` / ``parse_json``: the same checks, the message naming the file they live in.
"""

from __future__ import annotations

import dataclasses
import json
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from roman_sim.core.atomic import write_json
from roman_sim.core.config_errors import format_validation_error
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSON, JSONLike

T = TypeVar("T")

#: Field metadata: leave the field out of the JSON when it is None (and read it as None when absent).
OMIT_NONE: Mapping[str, Any] = {"omit_none": True}
#: Field metadata: leave the field out of the JSON when it is empty (read as its default when absent).
OMIT_EMPTY: Mapping[str, Any] = {"omit_empty": True}
#: Field metadata: None is written as an empty object, and an empty object read as None.
NONE_AS_EMPTY: Mapping[str, Any] = {"none_as_empty": True}
#: Field metadata: the nested dataclass's fields (or the mapping's entries) sit at this level.
INLINE: Mapping[str, Any] = {"inline": True}

__all__ = [
    "INLINE",
    "NONE_AS_EMPTY",
    "OMIT_EMPTY",
    "OMIT_NONE",
    "RecordError",
    "dumps_record",
    "from_json",
    "json_key",
    "loads_record",
    "parse_json",
    "read_json",
    "read_record",
    "to_json",
    "to_json_object",
    "to_json_record",
    "via",
    "write_record",
]


def json_key(key: str) -> dict[str, Any]:
    """Field metadata: the field is written under ``key`` (a JSON key that is not a Python name)."""
    return {"key": key}


def _key(f: dataclasses.Field[Any]) -> str:
    return str(f.metadata.get("key", f.name))


@dataclasses.dataclass(frozen=True)
class _Via:
    json_type: Any
    encode: Callable[[Any], Any]
    decode: Callable[[Any], Any]


def via(json_type: Any, encode: Callable[[Any], Any], decode: Callable[[Any], Any]) -> dict[str, Any]:
    """Field metadata: the value is written as ``encode(value)`` (of type ``json_type``) and read back
    as ``decode(v)`` of the ``json_type`` value ``v`` read; a ``ValueError`` of ``decode`` names the field."""
    return {"via": _Via(json_type, encode, decode)}


class RecordError(StorageError):
    """A JSON record that does not match its dataclass: names the file and the field."""


class _Mismatch(Exception):
    """A value that does not match its type (``where`` is the field path, ``what`` the problem)."""

    def __init__(self, where: str, what: str) -> None:
        super().__init__(f"field {where}: {what}" if where else what)


def to_json(obj: Any) -> JSON:
    """``obj`` as JSON values: dataclasses as objects (field order, shaped by their fields'
    metadata), pydantic models as their JSON dump, tuples as lists."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: dict[str, JSON] = {}
        for f in dataclasses.fields(obj):
            _put(out, f, getattr(obj, f.name), type(obj).__name__)
        return out
    if isinstance(obj, BaseModel):
        return typing.cast(JSON, obj.model_dump(mode="json"))
    if isinstance(obj, Mapping):
        return {str(k): to_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_json(v) for v in obj]
    if obj is None or isinstance(obj, (str, int, float, bool)):
        return obj
    raise TypeError(f"not a JSON record value: {type(obj).__name__}")


def to_json_object(obj: Any) -> dict[str, JSON]:
    """``to_json(obj)`` of a dataclass (or mapping): a JSON object."""
    data = to_json(obj)
    if not isinstance(data, dict):
        raise TypeError(f"not a JSON object record: {type(obj).__name__}")
    return data


def _put(out: dict[str, JSON], f: dataclasses.Field[Any], v: Any, owner: str) -> None:
    """Field ``f`` of value ``v`` into the JSON object ``out`` (as its metadata says)."""
    meta = f.metadata
    if v is None and meta.get("omit_none"):
        return
    if meta.get("omit_empty") and isinstance(v, (Mapping, list, tuple)) and not v:
        return
    if v is None and meta.get("none_as_empty"):
        out[_key(f)] = {}
        return
    conv: _Via | None = meta.get("via")
    value = to_json(v if conv is None or v is None else conv.encode(v))
    if not meta.get("inline"):
        out[_key(f)] = value
        return
    if not isinstance(value, dict):
        raise TypeError(f"{owner}.{f.name}: an inline field must be a dataclass or a mapping")
    clash = sorted(set(value) & set(out))
    if clash:
        raise TypeError(f"{owner}.{f.name}: inline key {clash[0]!r} is also a field")
    out.update(value)


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


def parse_json(text: str | bytes, source: str) -> Any:
    """The JSON document ``text`` (from ``source``, e.g. a header inside a file), parsed but not checked.

    Raises:
        RecordError: ``text`` is not UTF-8 or not JSON (the message names ``source``).
    """
    try:
        return json.loads(text)
    except UnicodeDecodeError:
        raise RecordError(f"{source}: not a JSON document (not UTF-8 text)") from None
    except json.JSONDecodeError as err:
        raise RecordError(f"{source}: not valid JSON (line {err.lineno}: {err.msg})") from None


def loads_record(text: str | bytes, cls: type[T], source: str, schema: str | None = None) -> T:
    """The ``cls`` record in the JSON document ``text`` (``from_json`` of ``parse_json``)."""
    return from_json(cls, parse_json(text, source), source, schema)


def dumps_record(obj: Any, schema: str | None = None) -> str:
    """The record ``obj`` as one line of JSON (sorted keys; the text ``loads_record`` reads)."""
    return json.dumps(to_json_record(obj, schema), sort_keys=True)


def read_record(path: str | Path, cls: type[T], schema: str | None = None) -> T:
    """The ``cls`` record in the JSON file ``path`` (its ``schema`` field must be ``schema`` when given).

    Raises:
        RecordError: the file is missing, unreadable, not JSON, of another schema, or a field
            is missing or of another type (the message names the file and the field).
    """
    return from_json(cls, read_json(path), str(path), schema)


def to_json_record(obj: Any, schema: str | None = None) -> JSON:
    """``to_json(obj)`` with a ``schema`` field first when given (``obj`` then a dataclass or mapping)."""
    if schema is None:
        return to_json(obj)
    return {"schema": schema, **to_json_object(obj)}


def write_record(
    path: str | Path, obj: Any, schema: str | None = None, indent: int | None = 2, tight: bool = False
) -> Path:
    """Atomically write the dataclass ``obj`` as JSON (with a ``schema`` field when given); returns ``path``.

    ``indent=None`` writes it on one line, ``tight`` on one line without spaces (sorted keys either way).
    """
    write_json(path, to_json_record(obj, schema), indent=indent, tight=tight)
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
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return _decode_model(tp, v, where)
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
        key, val = (args[0], args[1]) if len(args) == 2 else (str, Any)
        if typing.get_origin(key) is typing.Literal:
            bad = [k for k in v if k not in typing.get_args(key)]
            if bad:
                name = f"{where}.{bad[0]}" if where else bad[0]
                raise _Mismatch(name, "unknown key (valid: " + ", ".join(typing.get_args(key)) + ")")
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


def _decode_model(model: type[BaseModel], v: Any, where: str) -> BaseModel:
    """A pydantic model; its first validation error names the field below ``where``."""
    if not isinstance(v, dict):
        raise _Mismatch(where, f"expected an object, got {_kind(v)}")
    try:
        return model.model_validate(v)
    except ValidationError as err:
        loc, _, what = format_validation_error(err, "", model).partition(": ")
        loc = "" if loc == "<root>" else loc
        raise _Mismatch(".".join(x for x in (where, loc) if x), what) from None


def _keys(cls: type) -> tuple[list[str], bool]:
    """The JSON keys a dataclass's fields claim (inline ones included), and whether an inline
    mapping takes the other keys."""
    hints = typing.get_type_hints(cls)
    keys: list[str] = []
    rest = False
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        if not f.metadata.get("inline"):
            keys.append(_key(f))
            continue
        tp = _json_type(f, hints[f.name])
        if dataclasses.is_dataclass(tp) and isinstance(tp, type):
            sub, sub_rest = _keys(tp)
            keys += sub
            rest = rest or sub_rest
        else:
            rest = True
    return keys, rest


def _json_type(f: dataclasses.Field[Any], hint: Any) -> Any:
    conv: _Via | None = f.metadata.get("via")
    return hint if conv is None else conv.json_type


def _decode_dataclass(cls: type, v: Any, where: str) -> Any:
    if not isinstance(v, dict):
        raise _Mismatch(where, f"expected an object, got {_kind(v)}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    keys, rest = _keys(cls)
    unknown = [k for k in v if k not in keys]
    if unknown and not rest:
        name = f"{where}.{unknown[0]}" if where else unknown[0]
        raise _Mismatch(name, f"unknown (valid: {', '.join(keys)})")
    values: dict[str, Any] = {}
    for name, f in fields.items():
        key = _key(f)
        path = f"{where}.{key}" if where else key
        tp = _json_type(f, hints[name])
        if f.metadata.get("inline"):
            if dataclasses.is_dataclass(tp) and isinstance(tp, type):
                mine = set(_keys(tp)[0])
                raw: Any = {k: x for k, x in v.items() if k in mine or (k in unknown and _keys(tp)[1])}
            else:
                raw = {k: x for k, x in v.items() if k in unknown}
            values[name] = _convert(f, _decode(tp, raw, where), path)
            continue
        if key not in v:
            if f.metadata.get("omit_none"):
                values[name] = None
                continue
            if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING:
                continue
            raise _Mismatch(path, "missing")
        if (f.metadata.get("none_as_empty") and v[key] == {}) or (v[key] is None and _optional(hints[name])):
            values[name] = None
            continue
        values[name] = _convert(f, _decode(tp, v[key], path), path)
    return cls(**values)


def _optional(tp: Any) -> bool:
    """Whether the type ``tp`` admits None."""
    return tp is type(None) or (
        typing.get_origin(tp) in (typing.Union, types.UnionType) and type(None) in typing.get_args(tp)
    )


def _convert(f: dataclasses.Field[Any], value: Any, path: str) -> Any:
    """``value`` read as the field's JSON type, turned into the field's type (``via``)."""
    conv: _Via | None = f.metadata.get("via")
    if conv is None:
        return value
    try:
        return conv.decode(value)
    except ValueError as err:
        raise _Mismatch(path, str(err)) from None
