"""What the map builder asks of a front end: the ``Segmenter`` and ``SemanticEncoder`` protocols.

Implementations live in ``roman_sim.frontend`` (simulated, pixel and model front ends) or in
a user's own module. A component that reads ground truth says so with a class attribute
``reads_truth = True``; only then does the map builder hand it the frame's truth.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.sensors import Frame
from roman_sim.mapping.mask import Mask


@runtime_checkable
class Segmenter(Protocol):
    """Anything that turns a frame into masks (an image model never reads ``frame.truth``)."""

    def segment(self, frame: Frame) -> list[Mask]:
        """Masks of one frame."""
        ...


@dataclass
class EncodeContext:
    """What a simulated encoder may know about an observation (a real model ignores it).

    Attributes:
        object_id: true majority object id under the mask (-1 for terrain), or None when
            the frame carries no ground truth (a truth-driven encoder cannot run then).
        family: family name; looked up from ``object_id`` when None.
        view_dir: (3,) viewing direction camera -> object in the world frame, or None.
        shares: ``(object id, share)`` of every true object under the mask's pixels (terrain
            -1 included; shares sum to 1), or None: what a mask that merged several objects
            shows, for an encoder that describes a mask by its pixels.
    """

    object_id: int | None = None
    family: str | None = None
    view_dir: NDArray[np.float64] | None = None
    shares: tuple[tuple[int, float], ...] | None = None


@runtime_checkable
class SemanticEncoder(Protocol):
    """Image crop + mask -> unit float32 descriptor (CLIP, DINO, or a simulation)."""

    def encode(
        self, rgb_crop: NDArray[np.uint8] | None, mask: NDArray[np.bool_], context: EncodeContext
    ) -> NDArray[np.float32]:
        """Unit descriptor of one masked observation."""
        ...


def reads_truth(component: object) -> bool:
    """Whether a built component reads ground truth (its ``reads_truth`` attribute; False when absent)."""
    return bool(getattr(component, "reads_truth", False))
