"""Alignment of two submaps: ROMAN (CLIPPER with gravity, shape and semantics) and baselines (RANSAC, visual).

Importing this package registers every built-in method in ``ALIGNERS``; use
``build_aligner(name, params)`` to construct one.
"""

from roman_sim.align import peers as _peers  # noqa: F401  (registers ransac*, kiss_matcher)
from roman_sim.align import visual as _visual  # noqa: F401  (registers visual)
from roman_sim.align.aligners import RomanAligner, RomanParams, build_aligner
from roman_sim.align.base import ALIGNERS, Aligner, AlignResult

__all__ = ["ALIGNERS", "AlignResult", "Aligner", "RomanAligner", "RomanParams", "build_aligner"]
