"""The ``roman-sim`` command line: a thin wrapper over the library.

Each area adds its commands from its own module (``world``, ``record``, ``run``, ...).
Any ``RomanSimError`` becomes one line on stderr and exit code 1; a traceback means a bug.
"""

from __future__ import annotations

import logging
import sys
from typing import Any

import typer

from roman_sim.errors import RomanSimError


class _App(typer.Typer):
    """Typer app that turns ``RomanSimError`` into one clear line and exit code 1."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        try:
            return super().__call__(*args, **kwargs)
        except RomanSimError as err:
            typer.echo(f"error: {err}", err=True)
            sys.exit(1)


app = _App(
    name="roman-sim",
    help="Simulation testbed for ROMAN global localization with open-set object maps.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


@app.callback()
def _main(verbose: bool = typer.Option(False, "--verbose", "-v", help="Debug logging.")) -> None:
    logging.basicConfig(
        level=logging.DEBUG if verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )


def _register() -> None:
    """Import the command modules; each attaches its commands to ``app``."""
    import importlib
    import pkgutil

    for mod in sorted(m.name for m in pkgutil.iter_modules(__path__)):
        if not mod.startswith("_"):
            importlib.import_module(f"{__name__}.{mod}")


_register()
