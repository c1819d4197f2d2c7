"""The heading x ambiguity benchmark: suites of crossing scenes, their cells, the job and the leaderboard.

- ``suites``: which crossing scenes, ambiguity levels, seeds and methods a benchmark runs;
- ``scenes``: the crossing scene (many robots crossing one site at spread headings);
- ``plan``: the relevant pairs of a scenario from its planned trajectories, before rendering;
- ``cells``: one (level, seed) cell, planned and run as executor tasks, and its kept files;
- ``run``: the resumable job (``BenchmarkJob``);
- ``board``: the leaderboard, re-derived from the kept raw pairs only;
- ``check``: a finished board checked on fresh seeds at its deployed thresholds (``roman-sim benchmark check``);
- ``envelope``: one suite run per front end and which of its verdicts hold for every front end.
"""
