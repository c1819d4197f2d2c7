"""roman_sim: a simulation testbed for ROMAN global localization with open-set object maps.

Importing the package sets headless rendering defaults (``MUJOCO_GL=egl`` and
``PYOPENGL_PLATFORM=egl``) when they are unset, before any renderer is imported, and
registers the gymnasium environment ``roman_sim/GroundRobot-v0`` (as soon as gymnasium is
imported; importing roman_sim itself loads neither gymnasium nor MuJoCo).
"""

from __future__ import annotations

import logging
import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

from roman_sim.core import gymreg as _gymreg  # noqa: E402
from roman_sim.core.errors import (  # noqa: E402
    AlignmentError,
    ConfigError,
    EvaluationError,
    MappingError,
    RecordingError,
    RomanSimError,
    SimError,
    StorageError,
    WorldError,
)

__version__ = "0.1.0"

_gymreg.install()

logging.getLogger(__name__).addHandler(logging.NullHandler())

__all__ = [
    "__version__",
    "RomanSimError",
    "ConfigError",
    "WorldError",
    "SimError",
    "MappingError",
    "AlignmentError",
    "EvaluationError",
    "RecordingError",
    "StorageError",
]
