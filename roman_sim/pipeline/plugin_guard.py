"""Run-time guards of user plug-ins: an exception or a wrong return becomes one ``PluginError`` line.

A guarded aligner names the submap pair, a guarded segmenter the frame, a guarded encoder
the frame whose mask it was describing. Built-in components are not wrapped (they raise
the package's own errors). Typical use in the stages that call plug-ins::

    aligner = guard_aligner(build_aligner(entry.method, entry.params), entry.method)
    segmenter, encoder = guard_frontend(segmenter, fe.segmenter, encoder, fe.encoder)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from roman_sim.core.errors import PluginError
from roman_sim.core.registry import one_line
from roman_sim.pipeline.plugins import check_result


def is_plugin(name: Any) -> bool:
    """Whether a configured name is a user plug-in (``package.module:Class``)."""
    return isinstance(name, str) and ":" in name


def _fail(kind: str, path: str, where: str, err: BaseException) -> PluginError:
    if isinstance(err, PluginError):
        return err
    return PluginError(f"{kind} {path!r} failed on {where}: {type(err).__name__}: {one_line(err)}", path, kind)


class GuardedAligner:
    """An aligner plug-in whose failures inside ``align`` name the plug-in and the pair."""

    def __init__(self, inner: Any, path: str) -> None:
        self.inner, self.path = inner, path
        self.name = inner.name

    def align(self, a: Any, b: Any) -> Any:
        where = f"pair {a.name} - {b.name}"
        try:
            out = self.inner.align(a, b)
        except Exception as err:  # anything the user's code raises
            raise _fail("aligner", self.path, where, err) from None
        problem = check_result("aligner", out, (a, b))
        if problem:
            raise PluginError(f"aligner {self.path!r} on {where}: {problem}", self.path, "aligner")
        return out


class GuardedSegmenter:
    """A segmenter that remembers the frame it works on; for a plug-in, failures name that frame."""

    def __init__(self, inner: Any, path: str | None) -> None:
        self.inner, self.path = inner, path
        self.frame: str = "no frame yet"
        # What the wrapped component declares decides which frames it gets (truth or not).
        self.reads_truth = bool(getattr(inner, "reads_truth", False))

    def segment(self, frame: Any) -> Any:
        self.frame = f"frame {frame.index} of robot {frame.robot}"
        if self.path is None:
            return self.inner.segment(frame)
        try:
            out = self.inner.segment(frame)
        except Exception as err:  # anything the user's code raises
            raise _fail("segmenter", self.path, self.frame, err) from None
        problem = check_result("segmenter", out, (frame,))
        if problem:
            raise PluginError(f"segmenter {self.path!r} on {self.frame}: {problem}", self.path, "segmenter")
        return out


class GuardedEncoder:
    """An encoder plug-in whose failures name the frame (from ``frames``) and whose descriptors keep one size."""

    def __init__(self, inner: Any, path: str, frames: GuardedSegmenter | None = None) -> None:
        self.inner, self.path, self.frames = inner, path, frames
        self.dim: int | None = None
        self.reads_truth = bool(getattr(inner, "reads_truth", False))
        if callable(getattr(inner, "encode_batch", None)):
            self.encode_batch = self._encode_batch  # the mapper uses the batch call when there is one

    def _encode_batch(self, rgb: Any, masks: Any, contexts: Any) -> Any:
        where = "the masks of " + (self.frames.frame if self.frames is not None else "a frame")
        try:
            out = np.asarray(self.inner.encode_batch(rgb, masks, contexts))
        except Exception as err:  # anything the user's code raises
            raise _fail("encoder", self.path, where, err) from None
        for row in out if out.ndim == 2 else [out]:
            problem = check_result("encoder", row, (None, None, None))
            if problem:
                raise PluginError(f"encoder {self.path!r} on {where}: encode_batch: {problem}", self.path, "encoder")
        return out

    def encode(self, rgb_crop: Any, mask: Any, context: Any) -> Any:
        where = "a mask of " + (self.frames.frame if self.frames is not None else "a frame")
        try:
            out = self.inner.encode(rgb_crop, mask, context)
        except Exception as err:  # anything the user's code raises
            raise _fail("encoder", self.path, where, err) from None
        problem = check_result("encoder", out, (rgb_crop, mask, context))
        if problem is None:
            n = int(np.asarray(out).size)
            if self.dim is not None and n != self.dim:
                problem = f"encode(...) returned {n} values, earlier descriptors had {self.dim}"
            self.dim = n
        if problem:
            raise PluginError(f"encoder {self.path!r} on {where}: {problem}", self.path, "encoder")
        return out


def guard_aligner(aligner: Any, method: str) -> Any:
    """``aligner`` guarded when ``method`` names a plug-in, else itself."""
    return GuardedAligner(aligner, method) if is_plugin(method) else aligner


def guard_frontend(segmenter: Any, segmenter_name: Any, encoder: Any, encoder_name: Any) -> tuple[Any, Any]:
    """(segmenter, encoder) with every plug-in guarded; the segmenter tracks frames for the encoder's messages."""
    seg_plugin, enc_plugin = is_plugin(segmenter_name), is_plugin(encoder_name)
    if seg_plugin or enc_plugin:
        segmenter = GuardedSegmenter(segmenter, segmenter_name if seg_plugin else None)
    if enc_plugin:
        encoder = GuardedEncoder(encoder, encoder_name, segmenter)
    return segmenter, encoder
