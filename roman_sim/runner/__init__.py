"""Where tasks run, knowing nothing of stages: executors (serial, local pool, Dask), TLS, the
cluster probe, the workers' lifeline and preload, the task runner and its checkpoints."""
