"""The shared stage cache: a stage computed in one run folder is reused in any other.

A stage's cache key says everything its output depends on (configuration, inputs' keys,
code; ``roman_sim.pipeline.stages.base``), so the same key in another run folder means the
same files. Every completed stage is published here, and a run looks here for each stage
its own folder does not hold, before computing it: adding an aligner to a run in a new
folder then reuses the maps (nothing is rendered again).

Location: ``$ROMAN_SIM_CACHE`` when set (``off`` disables the cache), else
``$XDG_CACHE_HOME/roman_sim`` or ``~/.cache/roman_sim``. An entry is the folder
``stages/<stage>/<key>-<environment>/`` holding ``entry.json`` (stage, key, the library
versions of ``manifest.environment()``, each file's size) and the stage's files under
``files/`` at their paths in the run folder. Files are hard-linked (copied when the cache is
on another file system), both ways, so an entry costs no space while a run folder holding
the same files exists; every writer of a run folder replaces files (``roman_sim.core.atomic``),
never edits them in place, so a linked file never changes under the other folder.

An entry is valid when ``entry.json`` reads back with the stage and key asked for and every
file is there with its recorded size. It is built in a temporary folder next to its place
and renamed there in one step: two runs publishing the same entry both succeed, one rename
wins, and a reader never sees half an entry. Files taken into a run folder are linked to a
temporary name and renamed over their place, so an interrupted fetch leaves no partial file
under a stage's name. Library versions are part of an entry's name: a run reuses only what
was computed with the versions it runs with. The cache never fails a run: a publish or a
fetch that cannot be done is logged and skipped.

Clearing it is deleting its folder (``roman-sim cache --clear``); a run folder keeps its
own files.
"""

from __future__ import annotations

import errno
import logging
import os
import shutil
import uuid
from dataclasses import dataclass
from pathlib import Path

from roman_sim.core.config import stable_hash
from roman_sim.core.errors import RomanSimError
from roman_sim.core.records import RecordError, read_record, write_record

log = logging.getLogger(__name__)

#: Environment variable naming the cache folder (``off``: no shared cache).
CACHE_ENV = "ROMAN_SIM_CACHE"
#: Values of ``CACHE_ENV`` that turn the cache off.
OFF = frozenset({"off", "0", "false", "no", "none"})
ENTRY_JSON = "entry.json"
ENTRY_SCHEMA = "roman_sim.cache/1"


def default_cache_dir() -> Path | None:
    """The shared cache's folder (None when ``$ROMAN_SIM_CACHE`` turns it off)."""
    value = os.environ.get(CACHE_ENV)
    if value is not None and value.strip():
        return None if value.strip().lower() in OFF else Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "roman_sim"


def _link(src: Path, dst: Path) -> None:
    """``dst`` gets ``src``'s content: hard-linked (copied across file systems) to a temporary name, renamed."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.parent / f".{dst.name}.{uuid.uuid4().hex[:8]}.tmp"
    try:
        try:
            os.link(src, tmp)
        except OSError as err:
            if err.errno not in (errno.EXDEV, errno.EPERM, errno.EMLINK, errno.ENOTSUP, errno.EACCES):
                raise
            shutil.copyfile(src, tmp)
        os.replace(tmp, dst)
    finally:
        if tmp.exists():
            tmp.unlink()


@dataclass
class CacheEntry:
    """What an entry's ``entry.json`` holds: the stage, its key, the library versions, each file's size."""

    stage: str
    key: str
    environment: dict[str, str]
    files: dict[str, int]


@dataclass(frozen=True)
class StageCache:
    """The shared stage cache in ``root`` (see the module docstring)."""

    root: Path

    @classmethod
    def default(cls) -> StageCache | None:
        """The cache of ``default_cache_dir()`` (None when turned off)."""
        where = default_cache_dir()
        return None if where is None else cls(where)

    def entry_dir(self, stage: str, key: str, environment: dict[str, str]) -> Path:
        """The folder of the entry of ``stage`` with ``key``, computed with ``environment``'s library versions."""
        return self.root / "stages" / stage / f"{key}-{stable_hash(environment)[:8]}"

    def _read(self, entry: Path, stage: str, key: str) -> dict[str, int] | None:
        """The entry's files and sizes when it is valid, else None."""
        try:
            rec = read_record(entry / ENTRY_JSON, CacheEntry, ENTRY_SCHEMA)
            if rec.stage != stage or rec.key != key:
                return None
            for f, n in rec.files.items():
                if (entry / "files" / f).stat().st_size != n:
                    return None
        except (OSError, RecordError):
            return None
        return rec.files

    def lookup(self, stage: str, key: str, environment: dict[str, str]) -> Path | None:
        """The folder holding a valid entry's files (at their paths in a run folder), or None when there is none."""
        entry = self.entry_dir(stage, key, environment)
        return None if self._read(entry, stage, key) is None else entry / "files"

    def fetch(self, stage: str, key: str, environment: dict[str, str], run_dir: Path) -> list[str] | None:
        """Put the files of a valid entry into ``run_dir``; their relative paths, or None when there is none."""
        entry = self.entry_dir(stage, key, environment)
        files = self._read(entry, stage, key)
        if files is None:
            return None
        try:
            for f in files:
                _link(entry / "files" / f, run_dir / f)
        except OSError as err:  # the entry went away meanwhile (cleared), or the run folder refused
            log.warning("shared cache: could not take stage %s from %s (%s); computing it", stage, entry, err)
            return None
        log.info("stage %s: taken from the shared cache (%s)", stage, entry)
        return list(files)

    def publish(self, stage: str, key: str, environment: dict[str, str], run_dir: Path, files: list[str]) -> None:
        """Store the stage's ``files`` (relative to ``run_dir``) as an entry, unless a valid one is there."""
        entry = self.entry_dir(stage, key, environment)
        if self._read(entry, stage, key) is not None:
            return
        tmp = entry.parent / f".{entry.name}.{uuid.uuid4().hex[:8]}.tmp"
        try:
            for f in files:
                _link(run_dir / f, tmp / "files" / f)
            sizes = {f: (tmp / "files" / f).stat().st_size for f in files}
            write_record(tmp / ENTRY_JSON, CacheEntry(stage, key, dict(environment), sizes), ENTRY_SCHEMA)
            if entry.exists():  # an invalid entry (a file lost): replace it
                shutil.rmtree(entry, ignore_errors=True)
            os.rename(tmp, entry)
        except (OSError, RomanSimError) as err:
            # another run renamed its copy into place first (ENOTEMPTY / EEXIST), or the cache cannot be written
            if not (isinstance(err, OSError) and err.errno in (errno.ENOTEMPTY, errno.EEXIST)):
                log.warning("shared cache: could not store stage %s in %s (%s)", stage, self.root, err)
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)

    def entries(self) -> list[Path]:
        """The entries' folders, sorted (valid or not)."""
        base = self.root / "stages"
        if not base.is_dir():
            return []
        return sorted(p for stage in base.iterdir() if stage.is_dir() for p in stage.iterdir() if p.is_dir())

    def size_bytes(self) -> int:
        """Bytes the cache's files take (each hard link counted once per file name)."""
        return sum(p.stat().st_size for p in self.root.rglob("*") if p.is_file()) if self.root.is_dir() else 0

    def clear(self) -> int:
        """Delete every entry; how many there were."""
        n = len(self.entries())
        if (self.root / "stages").exists():
            shutil.rmtree(self.root / "stages")
        return n
