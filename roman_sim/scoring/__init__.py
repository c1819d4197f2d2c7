"""Scoring other systems' loop closures against the truth of a run or an exported sequence.

- ``external``: ``roman-sim score``: a closure file (CSV, g2o, the reference ROMAN's per-pair
  output, Kimera-Multi's logs) read, its stamps matched to frames, its closures put on the
  run's submap pairs and scored by the pipeline's own evaluation, with its ATE;
- ``closure_pairs``: closures matched to submap pairs, as arrays;
- ``closure_conventions``: the file scored under every other convention (quaternion order,
  inverted edges, swapped robots), so a wrong one is named.
"""
