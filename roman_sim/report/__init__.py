"""What a person reads: plots, tables and the markdown report of a run."""
