"""Interoperability: export scenarios as standard sequences, import real or exported ones.

- ``export_scenario``: every robot of a scenario as a TUM RGB-D folder or a ROS 2 bag,
  with exact ground truth, instance masks and the object table.
- ``read_tum_sequence``: a TUM RGB-D folder (real or exported) as ``Frame`` objects,
  ground truth kept apart in ``frame.truth``.
"""

from roman_sim.interop.export import ExportResult, export_scenario

__all__ = ["ExportResult", "export_scenario"]
