"""Plug-in checks before a run: one dry call on a tiny synthetic input, and return-type checks.

``load_plugin`` imports the plug-in, builds it, checks its protocol
(``roman_sim.core.plugins``) and makes one dry call on a tiny synthetic input: two
synthetic submaps (``roman_sim.align.synthetic``) for an aligner, a ray-cast frame of four
spheres (``roman_sim.mapping.synthetic``) for a segmenter, one of its masks for an encoder.
Every failure is one ``PluginError`` line naming the plug-in and what went wrong, so a
broken plug-in stops a run before its expensive stages. ``check_result`` is the return-type
check, shared with the run-time guards of ``roman_sim.pipeline.plugin_guard``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sized
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import PluginError
from roman_sim.core.plugins import describe, instantiate_plugin
from roman_sim.core.registry import one_line

if TYPE_CHECKING:
    from roman_sim.core.sensors import Frame
    from roman_sim.mapping.protocols import EncodeContext
    from roman_sim.mapping.types import Submap
    from roman_sim.pipeline.scenario import Scenario

UNIT_TOL = 1e-3  # |norm - 1| allowed of an encoder's descriptor (float32 rounding is ~1e-7)


def load_plugin(
    path: str, kind: str, params: dict[str, object] | None = None, *, descriptor_dim: int = 768, with_rgb: bool = True
) -> object:
    """Import, build, check and dry-run the plug-in ``path``; returns the built instance.

    Args:
        path: ``package.module:Class`` (a class, a factory function or an instance).
        kind: ``aligner``, ``segmenter`` or ``encoder``.
        params: keyword arguments of the constructor.
        descriptor_dim: descriptor size of the submaps given to an aligner's dry call.
        with_rgb: give the segmenter's and encoder's dry call an RGB image (else None,
            as in a run with ``render_rgb: false``).

    Raises:
        PluginError: it cannot be imported or built, lacks the protocol's methods, raises
            in the dry call or returns the wrong type.
    """
    obj = instantiate_plugin(path, kind, params)
    dry_call(obj, path, kind, descriptor_dim=descriptor_dim, with_rgb=with_rgb)
    return obj


def dry_call(obj: Any, path: str, kind: str, *, descriptor_dim: int = 768, with_rgb: bool = True) -> object:
    """Call ``obj`` once on a tiny synthetic input, check and return what it returned (``PluginError``)."""
    args: tuple[object, ...]
    call: Callable[..., object]
    if kind == "aligner":
        a, b = _dry_submaps(descriptor_dim)
        call, where, args = obj.align, "two synthetic submaps", (a, b)
    else:
        frame, mask, crop, ctx = _dry_frame(with_rgb)
        if kind == "segmenter":
            call, where, args = obj.segment, "a synthetic 64 x 48 frame", (frame,)
        else:
            call, where, args = obj.encode, "a mask of a synthetic frame", (crop, mask, ctx)
    try:
        out = call(*args)
    except Exception as err:  # the user's code may raise anything; report it in one line
        raise PluginError(
            f"{kind} {path!r}: the check on {where} raised {type(err).__name__}: {one_line(err)}", path, kind
        ) from None
    problem = check_result(kind, out, args)
    if problem:
        raise PluginError(f"{kind} {path!r}: on {where}, {problem}", path, kind)
    return out


def check_result(kind: str, out: object, args: tuple[object, ...]) -> str | None:
    """What is wrong with the value ``out`` a plug-in returned for ``args`` (None when it is fine)."""
    return _CHECKS[kind](out, args)


def _check_align(out: object, args: tuple[object, ...]) -> str | None:
    from roman_sim.align.base import AlignResult

    if not isinstance(out, AlignResult):
        return f"align(a, b) returned {describe(out)}, expected an AlignResult (roman_sim.align.base)"
    a, b = cast(tuple[Sized, Sized], args)
    if out.T_a_b is not None:
        T = np.asarray(out.T_a_b)
        if T.shape != (4, 4) or not np.issubdtype(T.dtype, np.number) or not np.all(np.isfinite(T)):
            return f"AlignResult.T_a_b is {describe(T)}, expected None or a finite 4 x 4 matrix"
    assoc = np.asarray(out.associations)
    if assoc.size and (assoc.ndim != 2 or assoc.shape[1] != 2 or not np.issubdtype(assoc.dtype, np.integer)):
        return f"AlignResult.associations is {describe(assoc)}, expected a (k, 2) integer array"
    # only segment associations index the submaps (others, e.g. feature matches, are not drawn or graded)
    info = out.info if isinstance(out.info, dict) else {}
    segments = info.get("association_kind", "segments") == "segments"
    if segments and assoc.size and (assoc.min() < 0 or assoc[:, 0].max() >= len(a) or assoc[:, 1].max() >= len(b)):
        return f"AlignResult.associations index segments outside the submaps ({len(a)} and {len(b)} segments)"
    if not isinstance(out.runtime_s, (int, float)) or not math.isfinite(out.runtime_s):
        return f"AlignResult.runtime_s is {describe(out.runtime_s)}, expected a finite number of seconds"
    return None


def _check_segment(out: object, args: tuple[object, ...]) -> str | None:
    from roman_sim.mapping.mask import Mask

    if not isinstance(out, (list, tuple)):
        return f"segment(frame) returned {describe(out)}, expected a list of Mask (roman_sim.frontend.segmenter)"
    shape = np.asarray(cast("Frame", args[0]).depth).shape
    for k, m in enumerate(out):
        if not isinstance(m, Mask):
            return f"segment(frame) returned a list whose item {k} is {describe(m)}, expected a Mask"
        pix = np.asarray(m.pixels)
        if pix.shape != shape or pix.dtype != np.bool_:
            return f"mask {k} is {describe(pix)}, expected a bool array of the frame's shape {shape}"
    return None


def _check_encode(out: object, args: tuple[object, ...]) -> str | None:
    if out is None or isinstance(out, (str, bytes, dict)):
        return f"encode(...) returned {describe(out)}, expected a unit float vector"
    try:
        v = np.asarray(out, dtype=np.float64)
    except (TypeError, ValueError):
        return f"encode(...) returned {describe(out)}, expected a unit float vector"
    if v.ndim != 1 or v.size == 0:
        return f"encode(...) returned {describe(np.asarray(out))}, expected a 1-d unit float vector"
    if not np.all(np.isfinite(v)):
        return "encode(...) returned a vector with NaN or infinite entries"
    norm = float(np.linalg.norm(v))
    if abs(norm - 1.0) > UNIT_TOL:
        return f"encode(...) returned a vector of norm {norm:.4g}, expected a unit vector (normalise it)"
    return None


_CHECKS: dict[str, Callable[[object, tuple[object, ...]], str | None]] = {
    "aligner": _check_align,
    "segmenter": _check_segment,
    "encoder": _check_encode,
}


def _dry_submaps(descriptor_dim: int) -> tuple[Submap, Submap]:
    from roman_sim.align.synthetic import make_submap_pair

    a, b, _ = make_submap_pair(seed=0, n_inliers=8, n_outliers_a=3, n_outliers_b=3, descriptor_dim=descriptor_dim)
    return a.public(), b.public()


def _dry_frame(with_rgb: bool) -> tuple[Frame, NDArray[np.bool_], NDArray[np.uint8] | None, EncodeContext]:
    """A 64 x 48 frame of four spheres (RGB coloured by object), one sphere's mask, its crop and context."""
    from dataclasses import replace

    from roman_sim.mapping import synthetic
    from roman_sim.mapping.protocols import EncodeContext

    intr = synthetic.intrinsics(64, 48)
    frame = synthetic.frame_at(synthetic.sphere_field(4, seed=0), 0.0, 0.0, 0.0, 0.0, 0, robot="check", intr=intr)
    assert frame.truth is not None  # frame_at always renders ids
    ids = np.asarray(frame.truth.object_ids)
    palette = np.array([[90, 110, 70], [200, 60, 50], [60, 160, 60], [70, 90, 200], [210, 190, 60]], np.uint8)
    if with_rgb:
        frame = replace(frame, rgb=palette[np.clip(ids + 1, 0, len(palette) - 1)])
    k = int(np.bincount(ids[ids >= 0]).argmax()) if np.any(ids >= 0) else -1
    pix = ids == k
    rows, cols = np.flatnonzero(pix.any(1)), np.flatnonzero(pix.any(0))
    r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    crop = None if frame.rgb is None else np.asarray(frame.rgb)[r0:r1, c0:c1]
    ctx = EncodeContext(object_id=k, view_dir=np.array([1.0, 0.0, 0.0]))
    return frame, pix[r0:r1, c0:c1], crop, ctx


def plugin_modules(scenario: Scenario) -> list[str]:
    """The ``package.module`` part of every ``module:Class`` plug-in a scenario names."""
    names = [a.method for a in scenario.aligners]
    fe = scenario.frontend
    names += [entry.name for entry in (fe.segmenter, fe.encoder)]
    return sorted({n.split(":", 1)[0] for n in names if ":" in n})
