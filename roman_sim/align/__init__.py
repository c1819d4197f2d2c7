"""Alignment of two submaps: ROMAN (CLIPPER with gravity, shape and semantics) and baselines.

Importing this package registers every built-in method in ``ALIGNERS``; use
``build_aligner(name, params)`` to construct one.
"""

from roman_sim.align import peers as _peers  # noqa: F401  (registers ransac*, kiss_matcher)
from roman_sim.align.aligners import RomanAligner, RomanParams, build_aligner
from roman_sim.align.base import ALIGNERS, Aligner, AlignResult

__all__ = ["ALIGNERS", "AlignResult", "Aligner", "RomanAligner", "RomanParams", "build_aligner"]
