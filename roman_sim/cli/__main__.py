"""``python -m roman_sim.cli``: the same as the ``roman-sim`` command."""

from roman_sim.cli import app

app(prog_name="roman-sim")
