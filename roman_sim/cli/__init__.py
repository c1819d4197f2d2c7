"""The ``roman-sim`` command line: a thin wrapper over the library.

Each area adds its commands from its own module (``world``, ``record``, ``run``, ...).
Any ``RomanSimError`` becomes one line on stderr and exit code 1; so do ``MemoryError`` and a
full disk; a traceback means a bug. With ``-v`` or ``--debug`` the full traceback of the error
and of its cause (a plug-in's own exception, with the file and line of its bug) follows the
line. Ctrl-C (SIGINT) ends a command with one line and exit
code 130, SIGTERM with one line and 143; results already written (completed stages) are
kept, since every file is written atomically (``roman_sim.cli._signals``: every exit code).
"""

from __future__ import annotations

import logging
from typing import Any, NoReturn

import typer
from typer.core import TyperGroup, TyperOption

from roman_sim.cli import _signals as S
from roman_sim.core.errors import RomanSimError, format_chain

_OPTION_TYPE = TyperOption.display_type_rich


def _plain_flag_type(self: TyperOption, ctx: Any) -> str | None:
    """Help shows a flag as ``--verbose -v``, not ``--verbose -v <bool>``: a flag takes no value."""
    return None if self.is_flag else _OPTION_TYPE(self, ctx)


TyperOption.display_type_rich = _plain_flag_type  # type: ignore[method-assign]

#: Whether ``-v`` / ``--debug`` asked for tracebacks below the one-line errors.
_TRACEBACKS = {"on": False}


def echo_traceback(err: BaseException) -> None:
    """With ``-v`` / ``--debug``: the tracebacks of ``err`` and of what lies behind it, on stderr."""
    if _TRACEBACKS["on"]:
        typer.echo(format_chain(err).rstrip("\n"), err=True)


def _echo_error(line: str, err: BaseException) -> None:
    typer.echo(f"error: {line}", err=True)
    echo_traceback(err)


class _Group(TyperGroup):
    """Command group that turns ``RomanSimError``, ``MemoryError``, a full disk and signals into one line."""

    # ``ctx`` is a click Context: the ``click`` package's in older typer, the copy typer vendors
    # (``typer._click``) in newer ones (0.29 here); ``Any`` keeps the override valid for both.
    def invoke(self, ctx: Any) -> Any:
        try:
            with S.stops_cleanly():
                return super().invoke(ctx)
        except RomanSimError as err:
            _echo_error(str(err), err)
            raise typer.Exit(1) from None
        except MemoryError as err:
            _echo_error(S.limit_line(err), err)
            raise typer.Exit(1) from None
        except OSError as err:
            if not S.is_disk_full(err):
                raise
            typer.echo(f"error: {S.disk_full_line(err, '.')}", err=True)
            raise typer.Exit(1) from None
        except KeyboardInterrupt as err:
            _stopped(err)
        except Exception as err:
            # a Ctrl-C that lands inside pydantic's serializer reaches here wrapped in its error
            if type(err).__name__ == "PydanticSerializationError" and "KeyboardInterrupt" in str(err):
                _stopped(KeyboardInterrupt())
            raise


def _stopped(err: KeyboardInterrupt) -> NoReturn:
    """The one line of a run stopped by a signal, and its exit code (130 for Ctrl-C)."""
    typer.echo(
        f"{S.stop_word(err)}: results written so far (completed stages) are kept; run the same command again to resume",
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


def _version(value: bool) -> None:
    """``--version``: print the package's version and stop."""
    if value:
        from importlib.metadata import version

        typer.echo(f"roman-sim {version('roman_sim')}")
        raise typer.Exit()


@app.callback()
def _main(
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Debug logging, and tracebacks below errors."),
    debug: bool = typer.Option(False, "--debug", help="Tracebacks below errors (a plug-in's own, with its line)."),
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version."),
) -> None:
    _TRACEBACKS["on"] = verbose or debug
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
