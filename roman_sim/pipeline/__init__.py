"""The stages of ``roman_sim.pipeline.experiment.Experiment`` (one module per group of stages)."""
