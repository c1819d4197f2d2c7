"""Seeding: one scenario seed -> one independent child Generator per named subsystem.

Children are keyed by a stable hash of their name (not by spawn order), so adding a new
subsystem never changes the random streams of the existing ones.
"""

from __future__ import annotations

import hashlib

import numpy as np


def _name_key(name: str) -> int:
    digest = hashlib.sha256(name.encode("utf-8")).digest()
    return int.from_bytes(digest[:4], "little")


def child_seedseq(seed: int, *names: str | int) -> np.random.SeedSequence:
    """SeedSequence for the subsystem path ``names`` under ``seed`` (stable across runs).

    Example: ``child_seedseq(7, "drift", "robot_a")``.
    """
    key = tuple(_name_key(n) if isinstance(n, str) else int(n) for n in names)
    return np.random.SeedSequence(entropy=int(seed), spawn_key=key)


def child_rng(seed: int, *names: str | int) -> np.random.Generator:
    """A Generator for the subsystem path ``names`` under ``seed``."""
    return np.random.default_rng(child_seedseq(seed, *names))
