"""The paper's visual-feature baseline: Kimera-Multi's loop closures (ORB + bag of binary words + 3D-3D RANSAC).

Robot side: ``KeyframeExtractor`` turns RGB-D frames into keyframes (ORB features with
depth, BoW vector from the shipped vocabulary) and ``attach_keyframes`` hands them to the
robot's submaps. Alignment side: the ``visual`` aligner (``VisualAligner``) compares two
submaps' keyframes. The vocabulary ships as package data (``default_vocabulary``) and is
re-trained bit-identically by ``python tools/train_vocabulary.py``.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

from roman_sim.align.visual.aligner import VisualAligner, VisualParams
from roman_sim.align.visual.keyframes import (
    Keyframe,
    KeyframeExtractor,
    KeyframeParams,
    attach_keyframes,
)
from roman_sim.align.visual.vocabulary import Vocabulary, train_vocabulary

#: File name of the shipped vocabulary inside ``roman_sim/align/visual/data``.
VOCABULARY_FILE = "orb_vocabulary.npz"


@lru_cache(maxsize=1)
def default_vocabulary() -> Vocabulary:
    """The shipped ORB vocabulary (loaded once)."""
    ref = resources.files("roman_sim.align.visual") / "data" / VOCABULARY_FILE
    with resources.as_file(ref) as path:
        return Vocabulary.load(path)


__all__ = [
    "VOCABULARY_FILE",
    "Keyframe",
    "KeyframeExtractor",
    "KeyframeParams",
    "VisualAligner",
    "VisualParams",
    "Vocabulary",
    "attach_keyframes",
    "default_vocabulary",
    "train_vocabulary",
]
