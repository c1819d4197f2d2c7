"""The stages of ``roman_sim.experiment.Experiment`` (one module per group of stages)."""
