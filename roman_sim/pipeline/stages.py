"""The stage functions used by ``Experiment.run`` in order."""

from roman_sim.pipeline.backend import (  # noqa: F401
    evaluation_files,
    evaluation_stage,
    load_stage,
    posegraph_files,
    posegraph_stage,
    report_stage,
)
from roman_sim.pipeline.frontend import map_files, maps_stage, submap_files, submaps_stage, world_stage  # noqa: F401
