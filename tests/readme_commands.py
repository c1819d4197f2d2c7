"""The README's two commands as CI takes them: each the one command between its ``ci:<name>`` markers.

``.ci/run`` runs the first (``first-command``: the open install and the demo) and then the
second (``test-command``: the locked install and the test suite) verbatim;
``tests/test_readme.py`` checks that its extraction gives exactly these strings.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
FIRST, TEST = "first-command", "test-command"


def markers(name: str) -> tuple[str, str]:
    """The begin and end markers of the README's command ``name``."""
    return f"<!-- ci:{name}:begin -->", f"<!-- ci:{name}:end -->"


def bash_commands(text: str) -> list[str]:
    """The command lines of the shell code blocks of ``text``, in order."""
    blocks = re.findall(r"^```bash\n(.*?)^```", text, flags=re.S | re.M)
    return [ln.strip() for b in blocks for ln in b.splitlines() if ln.strip()]


def marked_command(name: str, text: str | None = None) -> str:
    """The one command between the markers of ``name`` (AssertionError if not exactly one)."""
    text = README.read_text(encoding="utf-8") if text is None else text
    begin, end = markers(name)
    assert text.count(begin) == 1 and text.count(end) == 1, f"README.md: one {begin} and one {end}"
    (command,) = bash_commands(text[text.index(begin) : text.index(end)])
    return command


def no_deps_installs(command: str) -> list[str]:
    """The ``name==version`` requirements a command installs with ``pip install --no-deps``."""
    out = []
    for step in command.split("&&"):
        words = shlex.split(step)
        if words[:2] == ["pip", "install"] and "--no-deps" in words:
            out += [w for w in words[2:] if "==" in w]
    return out
