"""ROMAN's map builder: the front-end protocols, 3D segment tracking, submaps, storage.

The segmenters and encoders that implement the protocols live in ``roman_sim.frontend``.
Typical use (one robot)::

    mapper = Mapper(MappingConfig(), simulated_segmenter("fastsam", seed),
                    SimulatedEncoder(seed=seed, families=families, robot=name))
    for frame in robot_sources(world, [robot_cfg], seed)[0].frames():
        mapper.process(frame)
    segment_map = mapper.finish()
    submaps = build_submaps(segment_map, SubmapConfig())
"""

from __future__ import annotations

import importlib
from typing import Any

# Names are imported lazily so that ``roman_sim.mapping.types`` (used by alignment and
# evaluation) stays cheap to import and free of import cycles.
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(
        [
            "FORMAT_VERSION",
            "load_segment_map",
            "load_submaps",
            "mb_per_km",
            "packet_bytes",
            "save_segment_map",
            "save_submaps",
            "submaps_mb_per_km",
        ],
        "io",
    ),
    **dict.fromkeys(["Mapper", "SegmentMap"], "mapper"),
    **dict.fromkeys(["Segment", "Status"], "segment"),
    **dict.fromkeys(["Mask"], "mask"),
    **dict.fromkeys(["EncodeContext", "Segmenter", "SemanticEncoder", "reads_truth"], "protocols"),
    **dict.fromkeys(["SubmapConfig", "build_submaps"], "submap"),
    **dict.fromkeys(["MappingConfig", "Observation", "Tracker"], "tracker"),
    **dict.fromkeys(["Submap", "SubmapTruth"], "types"),
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'roman_sim.mapping' has no attribute {name!r}")
    return getattr(importlib.import_module(f"roman_sim.mapping.{_EXPORTS[name]}"), name)
