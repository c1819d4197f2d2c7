"""Run-time guards of user plug-ins: an exception or a wrong return becomes one ``PluginError`` line.

A guarded aligner names the submap pair, a guarded segmenter the frame, a guarded encoder
the frame whose mask it was describing. Built-in components are not wrapped (they raise
the package's own errors). Typical use in the stages that call plug-ins::

    aligner = guard_aligner(build_aligner(entry.method, entry.params), entry.method)
    segmenter, encoder = guard_frontend(segmenter, fe.segmenter, encoder, fe.encoder)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from roman_sim.align.base import Aligner, AlignResult
from roman_sim.core.errors import PluginError
from roman_sim.core.registry import one_line
from roman_sim.core.sensors import Frame
from roman_sim.mapping.mask import Mask
from roman_sim.mapping.protocols import EncodeContext, Segmenter, SemanticEncoder
from roman_sim.mapping.types import Submap
from roman_sim.pipeline.plugins import check_result


def is_plugin(name: object) -> bool:
    """Whether a configured name is a user plug-in (``package.module:Class``)."""
    return isinstance(name, str) and ":" in name


def _fail(kind: str, path: str, where: str, err: BaseException) -> PluginError:
    if isinstance(err, PluginError):
        return err
    return PluginError(f"{kind} {path!r} failed on {where}: {type(err).__name__}: {one_line(err)}", path, kind)


class GuardedAligner:
    """An aligner plug-in whose failures inside ``align`` name the plug-in and the pair."""

    def __init__(self, inner: Aligner, path: str) -> None:
        self.inner, self.path = inner, path
        self.name = inner.name

    def align(self, a: Submap, b: Submap) -> AlignResult:
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

    def __init__(self, inner: Segmenter, path: str | None) -> None:
        self.inner, self.path = inner, path
        self.frame: str = "no frame yet"
        # What the wrapped component declares decides which frames it gets (truth or not).
        self.reads_truth = bool(getattr(inner, "reads_truth", False))

    def segment(self, frame: Frame) -> list[Mask]:
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

    def __init__(self, inner: SemanticEncoder, path: str, frames: Segmenter | None = None) -> None:
        self.inner, self.path, self.frames = inner, path, frames
        self.dim: int | None = None
        self.reads_truth = bool(getattr(inner, "reads_truth", False))
        if callable(getattr(inner, "encode_batch", None)):
            self.encode_batch = self._encode_batch  # the mapper uses the batch call when there is one

    def _where(self, what: str) -> str:
        frame = self.frames.frame if isinstance(self.frames, GuardedSegmenter) else "a frame"
        return f"{what} {frame}"

    def _encode_batch(
        self, rgb: NDArray[np.uint8] | None, masks: Sequence[Mask], contexts: Sequence[EncodeContext]
    ) -> NDArray[np.float32]:
        where = self._where("the masks of")
        batch = self.inner.encode_batch  # type: ignore[attr-defined]  # only set when the plug-in has it
        try:
            out = np.asarray(batch(rgb, masks, contexts))
        except Exception as err:  # anything the user's code raises
            raise _fail("encoder", self.path, where, err) from None
        for row in out if out.ndim == 2 else [out]:
            problem = check_result("encoder", row, (None, None, None))
            if problem:
                raise PluginError(f"encoder {self.path!r} on {where}: encode_batch: {problem}", self.path, "encoder")
        return out

    def encode(
        self, rgb_crop: NDArray[np.uint8] | None, mask: NDArray[np.bool_], context: EncodeContext
    ) -> NDArray[np.float32]:
        where = self._where("a mask of")
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


def guard_aligner(aligner: Aligner, method: str) -> Aligner:
    """``aligner`` guarded when ``method`` names a plug-in, else itself."""
    return GuardedAligner(aligner, method) if is_plugin(method) else aligner


def guard_frontend(
    segmenter: Segmenter, segmenter_name: str, encoder: SemanticEncoder, encoder_name: str
) -> tuple[Segmenter, SemanticEncoder]:
    """(segmenter, encoder) with every plug-in guarded; the segmenter tracks frames for the encoder's messages."""
    seg_plugin, enc_plugin = is_plugin(segmenter_name), is_plugin(encoder_name)
    if seg_plugin or enc_plugin:
        segmenter = GuardedSegmenter(segmenter, segmenter_name if seg_plugin else None)
    if enc_plugin:
        encoder = GuardedEncoder(encoder, encoder_name, segmenter)
    return segmenter, encoder
