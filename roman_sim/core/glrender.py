"""Process-wide pyrender offscreen renderers.

pyrender's ``OffscreenRenderer.delete()`` terminates the EGL display, which MuJoCo's
rendering contexts share: after it, creating a MuJoCo renderer fails. Renderers are
therefore created once per image size and kept for the lifetime of the process.
"""

from __future__ import annotations

import functools
from typing import Any


@functools.lru_cache(maxsize=8)
def offscreen_renderer(width: int, height: int) -> Any:
    """The shared pyrender ``OffscreenRenderer`` of this size (never delete it)."""
    import pyrender  # deferred: needs the EGL platform that importing roman_sim sets

    return pyrender.OffscreenRenderer(width, height)
