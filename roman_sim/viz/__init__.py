"""3D views of finished runs (rerun recordings): objects, trajectories, maps, submaps,
loop closures and camera images on a timeline."""

from roman_sim.viz.rrd import recording_contents
from roman_sim.viz.view import ViewResult, open_viewer, write_run_view

__all__ = ["ViewResult", "open_viewer", "recording_contents", "write_run_view"]
