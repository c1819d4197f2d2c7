"""Fixtures shared by every test area."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from typer.testing import CliRunner


@pytest.fixture
def cli_fails() -> Callable[..., str]:
    """``cli_fails(*args)``: run ``roman-sim ARGS``, assert one clean error line and exit code 1, return the line.

    ``allow_progress=True`` also accepts progress-bar lines drawn before the error line.

    Fails the test when an exception other than ``SystemExit`` escapes the command (a
    traceback in a real shell) or stderr holds anything but the one ``error: ...`` line.
    """
    from roman_sim.cli import app

    def run(*args: object, allow_progress: bool = False) -> str:
        result = CliRunner().invoke(app, [str(a) for a in args])
        escaped = result.exception is not None and not isinstance(result.exception, SystemExit)
        assert not escaped, f"uncaught {type(result.exception).__name__}: {result.exception}"
        assert result.exit_code == 1, (result.exit_code, result.output)
        assert "Traceback" not in result.output
        lines = result.stderr.strip().splitlines()
        if allow_progress:  # a progress bar drawn before the failure (its lines hold no "error:")
            assert not any("error" in line.lower() for line in lines[:-1]), result.stderr
            lines = lines[-1:]
        assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
        return lines[0]

    return run
