"""``python -m roman_sim.cli``: the ``roman-sim`` command."""

from roman_sim.cli import app

app()
