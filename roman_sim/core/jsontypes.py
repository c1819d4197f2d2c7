"""JSON value types: what ``json.loads`` returns and what the atomic JSON writer takes.

``JSON`` is recursive (objects of JSON, lists of JSON, scalars). It is invariant like the
``dict`` and ``list`` it is made of, so a ``dict[str, float]`` is not a ``JSON`` object;
``JSONLike`` (read-only ``Mapping`` and ``Sequence``) accepts such values where a function
only reads its argument (e.g. before serialising it).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TypeAlias

from roman_sim.core.errors import StorageError

JSONScalar: TypeAlias = str | int | float | bool | None
JSON: TypeAlias = dict[str, "JSON"] | list["JSON"] | JSONScalar
JSONObject: TypeAlias = dict[str, JSON]
JSONLike: TypeAlias = Mapping[str, "JSONLike"] | Sequence["JSONLike"] | JSONScalar

__all__ = ["JSON", "JSONLike", "JSONObject", "JSONScalar", "read_record"]


def read_record(path: Path, schema: str, what: str) -> JSONObject:
    """The JSON object at ``path`` whose ``schema`` field is ``schema``.

    Raises: StorageError ``<path>: not a <what> (<error>)`` when the file is missing,
    unreadable, not an object or of another schema.
    """
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.get("schema") != schema:
            raise ValueError(f"schema {data.get('schema')!r}")
        return dict(data)
    except (OSError, ValueError, AttributeError) as err:
        raise StorageError(f"{path}: not a {what} ({type(err).__name__}: {err})") from None
