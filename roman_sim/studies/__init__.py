"""Studies that drive the whole testbed: the reference reproduction, its claims and tables, the
benchmark suites, and tools that run the simulator to train or calibrate (vocabulary, front end).
"""
