"""Interoperability: export scenarios as standard sequences, import real or exported ones.

- ``export_scenario``: every simulated robot of a scenario as a TUM RGB-D folder, a ROS 2
  bag or an EuRoC MAV folder (with its IMU and second camera, and Kalibr-style calibration),
  with exact ground truth, instance masks and the object table.
- ``read_tum_sequence`` / ``TumSequence``: a TUM RGB-D folder (real or exported) as
  ``Frame`` objects, ground truth kept apart in ``frame.truth``; ``TumSourceConfig`` is a
  scenario robot's ``source``.
- ``closure_files.read_closure_file``: any system's loop closures, in the format its file
  shows (this testbed's CSV, g2o with gtsam Symbol keys, the reference ROMAN's per-pair
  ``align`` output, Kimera-Multi's ``loop_closures.csv``), for ``roman-sim score``;
  ``stamps``: which clock a file's stamps are on, and stamps matched to frames.
"""

from roman_sim.interop.export import ExportResult, export_scenario
from roman_sim.interop.tum_reader import TumSequence, TumSourceConfig, read_tum_sequence

__all__ = ["ExportResult", "TumSequence", "TumSourceConfig", "export_scenario", "read_tum_sequence"]
