"""JSON value types: what ``json.loads`` returns and what the atomic JSON writer takes.

``JSON`` is recursive (objects of JSON, lists of JSON, scalars). It is invariant like the
``dict`` and ``list`` it is made of, so a ``dict[str, float]`` is not a ``JSON`` object;
``JSONLike`` (read-only ``Mapping`` and ``Sequence``) accepts such values where a function
only reads its argument (e.g. before serialising it).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TypeAlias

JSONScalar: TypeAlias = str | int | float | bool | None
JSON: TypeAlias = dict[str, "JSON"] | list["JSON"] | JSONScalar
JSONObject: TypeAlias = dict[str, JSON]
JSONLike: TypeAlias = Mapping[str, "JSONLike"] | Sequence["JSONLike"] | JSONScalar

__all__ = ["JSON", "JSONLike", "JSONObject", "JSONScalar"]
