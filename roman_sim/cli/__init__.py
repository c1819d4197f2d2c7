"""The ``roman-sim`` command line: a thin wrapper over the library.

Each area adds its commands from its own module (``world``, ``record``, ``run``, ...).
Any ``RomanSimError`` becomes one line on stderr and exit code 1; so do ``MemoryError`` and a
full disk; a traceback means a bug. Ctrl-C (SIGINT) ends a command with one line and exit
code 130, SIGTERM with one line and 143; results already written (completed stages) are
kept, since every file is written atomically (``roman_sim.cli._signals``: every exit code).
"""

from __future__ import annotations

import logging
from typing import Any

import typer
from typer.core import TyperGroup

from roman_sim.cli import _signals as S
from roman_sim.core.errors import RomanSimError


class _Group(TyperGroup):
    """Command group that turns ``RomanSimError``, ``MemoryError``, a full disk and signals into one line."""

    # ``ctx`` is a click Context: the ``click`` package's in older typer, the copy typer vendors
    # (``typer._click``) in newer ones (0.29 here); ``Any`` keeps the override valid for both.
    def invoke(self, ctx: Any) -> Any:
        try:
            with S.stops_cleanly():
                return super().invoke(ctx)
        except RomanSimError as err:
            typer.echo(f"error: {err}", err=True)
            raise typer.Exit(1) from None
        except MemoryError as err:
            typer.echo(f"error: {S.limit_line(err)}", err=True)
            raise typer.Exit(1) from None
        except OSError as err:
            if not S.is_disk_full(err):
                raise
            typer.echo(f"error: {S.disk_full_line(err, '.')}", err=True)
            raise typer.Exit(1) from None
        except KeyboardInterrupt as err:
            typer.echo(
                f"{S.stop_word(err)}: results written so far (completed stages) are kept; "
                "run the same command again to resume",
                err=True,
            )
            raise typer.Exit(S.stop_code(err)) from None


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
