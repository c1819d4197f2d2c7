"""Orchestration: scenario, run context, stage table, experiment (orders, caches, times), results,
sweeps and the reference results."""
