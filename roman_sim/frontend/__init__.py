"""What implements the map builder's protocols: simulated, pixel and model front ends.

- simulated perception, driven by the frame's truth: ``segmenter`` (the seeded segmenter and
  its error model: ``segmenter_errors``, ``mask_noise``, ``frame_objects``) and ``semantics``
  (the CLIP-like encoder and its ``confusion``; ``semantics_stats`` measures it);
- pixel front ends that see only the images: ``image_segmenter``, ``image_encoder``;
- adapters of real vision models (``models``: SAM, CLIP, DINOv2);
- the scenario's ``frontend`` section, its registered components and factories
  (``components``), bundled and file presets (``presets``), and the fit of the simulated
  front end to measured grades (``fit``).

Typical use (one robot)::

    mapper = Mapper(MappingConfig(), simulated_segmenter("fastsam", seed),
                    SimulatedEncoder(seed=seed, families=families, robot=name))
"""

from __future__ import annotations

import importlib
from typing import Any

# Names are imported lazily so that configuration models stay cheap to import.
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(["SEGMENTERS", "SegmenterConfig", "SimulatedSegmenter", "simulated_segmenter"], "segmenter"),
    **dict.fromkeys(["SemanticConfig", "SimulatedEncoder"], "semantics"),
    **dict.fromkeys(["FrontEndConfig", "build_encoder", "build_segmenter"], "components"),
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'roman_sim.frontend' has no attribute {name!r}")
    return getattr(importlib.import_module(f"roman_sim.frontend.{_EXPORTS[name]}"), name)
