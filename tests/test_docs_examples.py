"""Every Python and ``roman-sim`` code block of README.md and docs/*.md runs, outside the repository.

A block that cannot run here says why on the line before it: ``<!-- not run: <reason> -->``
(a paper-scale run, an install, a cluster). The others run in document order in one folder
outside the repository, so an example that only works from the repository root fails; the
smoke run they share is made once per session, and the README's comparison on the demo makes
the one demo run (about 2 minutes) a later example would reuse.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", flags=re.S | re.M)
NOT_RUN = re.compile(r"<!-- not run: (?P<reason>.*?\S)\s*-->\s*$")
#: The run the examples share: the README's plug-in command.
SMOKE_COMMAND = "roman-sim run smoke --aligner roman_sim.examples.mutual_nn_aligner:MutualNNAligner"


@dataclass(frozen=True)
class Block:
    """One fenced code block of a page."""

    page: str
    line: int
    lang: str
    body: str
    not_run: str | None

    @property
    def id(self) -> str:
        return f"{self.page}:{self.line}"

    def commands(self) -> list[str]:
        """The shell commands of a bash block (continuation lines joined, comments dropped)."""
        text = re.sub(r"\\\n\s*", " ", self.body)
        return [re.sub(r"\s+#.*$", "", ln).strip() for ln in text.splitlines() if ln.strip()]


def code_blocks() -> list[Block]:
    """The Python and shell blocks of every page, with their ``not run`` reason if any."""
    out = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for m in FENCE.finditer(text):
            if m.group(1) not in {"python", "bash"}:
                continue
            before = text[: m.start()].rstrip("\n").rsplit("\n", 1)[-1]
            mark = NOT_RUN.search(before)
            assert mark or "not run" not in before, f"{page.name}: a 'not run' marker that does not parse: {before}"
            rel = page.relative_to(ROOT).as_posix()
            line = text[: m.start()].count("\n") + 1
            out.append(Block(rel, line, m.group(1), m.group(2), mark.group("reason") if mark else None))
    return out


BLOCKS = code_blocks()
RUN = [b for b in BLOCKS if b.not_run is None]


def test_every_block_runs_or_says_why_not() -> None:
    assert len(BLOCKS) >= 20  # the pages were read
    for b in BLOCKS:
        if b.not_run is None and b.lang == "bash":
            bad = [c for c in b.commands() if not c.startswith("roman-sim ")]
            assert not bad, f"{b.id}: only roman-sim commands run here; mark the block <!-- not run: why -->: {bad}"
    assert RUN, "no block runs"


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    env.setdefault("PYOPENGL_PLATFORM", "egl")
    env["COLUMNS"] = "100"
    return env


def _check(cmd: list[str], cwd: Path, what: str) -> None:
    out = subprocess.run(cmd, cwd=cwd, env=_env(), capture_output=True, text=True, timeout=1800)
    assert out.returncode == 0, f"{what} exited {out.returncode}:\n{out.stdout[-3000:]}\n{out.stderr[-3000:]}"


@pytest.fixture(scope="session")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder outside the repository holding the smoke run the examples share."""
    d = tmp_path_factory.mktemp("docs_examples")
    assert not d.resolve().is_relative_to(ROOT)
    _check(SMOKE_COMMAND.split(), d, SMOKE_COMMAND)
    return d


@pytest.mark.parametrize("block", RUN, ids=[b.id for b in RUN])
def test_block_runs(block: Block, workdir: Path) -> None:
    if block.lang == "bash":
        for cmd in block.commands():
            _check(["bash", "-c", cmd], workdir, f"{block.id}: {cmd}")
        return
    name = re.sub(r"\W", "_", block.id) + ".py"
    src = workdir / ("test_" + name if re.search(r"^def test_", block.body, flags=re.M) else name)
    src.write_text(block.body, encoding="utf-8")
    if src.name.startswith("test_"):
        pytest_cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist", src.name]
        _check(pytest_cmd, workdir, block.id)
    else:
        _check([sys.executable, src.name], workdir, block.id)
