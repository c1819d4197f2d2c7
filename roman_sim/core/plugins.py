"""User plug-ins (aligners, segmenters, encoders named ``package.module:Class``): import and build.

``instantiate_plugin`` imports the plug-in, builds it and checks its protocol (the methods a
kind must have). Every failure is one ``PluginError`` line naming the plug-in and what went
wrong. The dry call on synthetic inputs and the return-type checks live with the pipeline
(``roman_sim.pipeline.plugins``), which knows the algorithm layers' types.
"""

from __future__ import annotations

from typing import Any, Literal, get_args

import numpy as np

from roman_sim.core.errors import PluginError, RomanSimError
from roman_sim.core.registry import import_object, one_line

PluginKind = Literal["aligner", "segmenter", "encoder"]
KINDS: tuple[str, ...] = get_args(PluginKind)

#: What each kind must provide, as told to the user when something is missing.
PROTOCOLS: dict[str, tuple[tuple[str, ...], str]] = {
    "aligner": (("name", "align"), "a 'name' and align(a, b) -> AlignResult"),
    "segmenter": (("segment",), "segment(frame) -> list[Mask]"),
    "encoder": (("encode",), "encode(rgb_crop, mask, context) -> unit float vector"),
}


def instantiate_plugin(path: str, kind: str, params: dict[str, Any] | None = None) -> object:
    """Import and build the plug-in and check its protocol (no dry call); ``PluginError`` on failure."""
    if kind not in KINDS:
        raise PluginError(f"plug-in kind {kind!r} unknown (valid: {', '.join(KINDS)})", path, kind)
    try:
        factory = import_object(path, kind)
    except RomanSimError as err:
        raise PluginError(str(err), path, kind) from None
    params = dict(params or {})
    if isinstance(factory, type) or (callable(factory) and not _has_protocol(factory, kind)):
        try:
            obj = factory(**params)
        except Exception as err:  # a user's constructor may raise anything
            args = f"**{params!r}" if params else ""
            raise PluginError(
                f"{kind} {path!r}: {_short(path)}({args}) raised {type(err).__name__}: {one_line(err)}", path, kind
            ) from None
    elif params:
        raise PluginError(f"{kind} {path!r}: is an instance, it cannot take parameters {sorted(params)}", path, kind)
    else:
        obj = factory
    check_protocol(obj, path, kind)
    return obj


def check_protocol(obj: object, path: str, kind: str) -> None:
    """``PluginError`` unless ``obj`` has the methods (and for an aligner a non-empty ``name``) of ``kind``."""
    names, what = PROTOCOLS[kind]
    for name in names:
        if name == "name":
            value = getattr(obj, "name", None)
            if not isinstance(value, str) or not value:
                raise PluginError(
                    f"{kind} {path!r}: needs a non-empty string attribute 'name' (got {value!r}); an {kind} has {what}",
                    path,
                    kind,
                )
        elif not callable(getattr(obj, name, None)):
            raise PluginError(
                f"{kind} {path!r}: {type(obj).__name__} has no method {name!r}; "
                f"a{'n' if kind[0] in 'ae' else ''} {kind} has {what}",
                path,
                kind,
            )


def describe(value: Any) -> str:
    """A value's type for a message: ``None``, ``a dict``, ``a str ('abc')``, ``a float32 array of shape (3,)``."""
    if value is None:
        return "None"
    if isinstance(value, np.ndarray):
        return f"a {value.dtype} array of shape {value.shape}"
    text = f"a {type(value).__name__}"
    if isinstance(value, (str, int, float)):
        text += f" ({value!r})" if len(repr(value)) <= 40 else ""
    return text


def _has_protocol(obj: object, kind: str) -> bool:
    return all(hasattr(obj, n) for n in PROTOCOLS[kind][0])


def _short(path: str) -> str:
    return path.split(":", 1)[-1]
