"""The ``roman-sim`` command line: a thin wrapper over the library.

Each area adds its commands from its own module (``world``, ``record``, ``run``, ...).
Any ``RomanSimError`` becomes one line on stderr and exit code 1; a traceback means a bug.
Ctrl-C (SIGINT) ends a command with one line and exit code 130; results already written
(completed stages) are kept, since every file is written atomically.
"""

from __future__ import annotations

import logging
from typing import Any

import typer
from typer.core import TyperGroup

from roman_sim.core.errors import RomanSimError


class _Group(TyperGroup):
    """Command group that turns ``RomanSimError`` into one clear line and exit code 1."""

    # ``ctx`` is a click Context: the ``click`` package's in older typer, the copy typer vendors
    # (``typer._click``) in newer ones (0.29 here); ``Any`` keeps the override valid for both.
    def invoke(self, ctx: Any) -> Any:
        try:
            return super().invoke(ctx)
        except RomanSimError as err:
            typer.echo(f"error: {err}", err=True)
            raise typer.Exit(1) from None
        except KeyboardInterrupt:
            typer.echo(
                "interrupted: results written so far (completed stages) are kept; run the same command again to resume",
                err=True,
            )
            raise typer.Exit(130) from None


app = typer.Typer(
    cls=_Group,
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
