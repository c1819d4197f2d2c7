"""The shared stage cache: a stage computed in one run folder is reused in any other, once verified.

A stage's cache key says everything its output depends on (configuration, inputs' keys,
code and the versions of the libraries the code imports; ``roman_sim.pipeline.stages.base``),
so the same key in another run folder means the same files. Every completed stage is
published here, and a run looks here for each stage its own folder does not hold, before
computing it: adding an aligner to a run in a new folder then reuses the maps (nothing is
rendered again).

Location: ``$ROMAN_SIM_CACHE`` when set (``off`` disables the cache), else
``$XDG_CACHE_HOME/roman_sim`` or ``~/.cache/roman_sim``; a location that exists and is not a
folder turns the cache off, with one warning per process. An entry is the folder
``stages/<stage>/<key>/`` holding ``entry.json`` (stage, key, and each file's path, size and
SHA-256, in the order the stage wrote them) and the stage's files under ``files/`` at their
paths in the run folder.

What the cache guarantees:

- **Reuse is verified.** An entry is used only when ``entry.json`` reads back with the stage
  and key asked for and every file has its recorded size and SHA-256. A file that does not
  (flipped bytes, an edit, a truncation) drops the whole entry with one warning naming the
  file, and the run computes the stage instead. ``roman-sim cache --verify`` checks every
  entry the same way.
- **No shared bytes.** Files are copied both ways, never linked: editing a file in a run
  folder changes neither the cache nor any other run folder. A file taken into a run folder
  is copied to a temporary name, its SHA-256 checked against the entry's, then renamed over
  its place, so an interrupted or failed fetch leaves no partial file under a stage's name.
  A published file is checked against the hash its run's manifest recorded.
- **Whole entries only.** An entry is built in a temporary folder next to its place and
  renamed there in one step: two runs publishing the same entry both succeed, one rename
  wins, and a reader never sees half an entry. A dropped entry is renamed away before it is
  deleted.
- **Never a failed run.** A publish or a fetch that cannot be done is logged and skipped.

Clearing it is deleting its folder (``roman-sim cache --clear``); a run folder keeps its
own files.
"""

from __future__ import annotations

import errno
import hashlib
import logging
import os
import shutil
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from roman_sim.core.errors import RomanSimError
from roman_sim.core.records import RecordError, read_record, write_record

log = logging.getLogger(__name__)

#: Environment variable naming the cache folder (``off``: no shared cache).
CACHE_ENV = "ROMAN_SIM_CACHE"
#: Values of ``CACHE_ENV`` that turn the cache off.
OFF = frozenset({"off", "0", "false", "no", "none"})
ENTRY_JSON = "entry.json"
ENTRY_SCHEMA = "roman_sim.cache/2"

_warned_not_a_folder: set[Path] = set()


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes, as 64 hex digits."""
    with path.open("rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def default_cache_dir() -> Path | None:
    """The shared cache's folder (None when ``$ROMAN_SIM_CACHE`` turns it off)."""
    value = os.environ.get(CACHE_ENV)
    if value is not None and value.strip():
        return None if value.strip().lower() in OFF else Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "roman_sim"


def not_a_folder(where: Path) -> str | None:
    """Why the cache cannot live at ``where`` (it, or a parent, exists and is not a folder), or None."""
    for p in [where, *where.parents]:
        if p.exists():
            return None if p.is_dir() else f"{p} is a file, not a folder"
    return None


def _tmp_name(dst: Path) -> Path:
    return dst.parent / f".{dst.name}.{uuid.uuid4().hex[:8]}.tmp"


def _copy_checked(src: Path, dst: Path, sha256: str | None) -> Path | None:
    """Copy ``src`` to a temporary name next to ``dst``; that name when its SHA-256 is ``sha256`` (or
    ``sha256`` is None), else None."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = _tmp_name(dst)
    try:
        shutil.copyfile(src, tmp)
        if sha256 is None or file_sha256(tmp) == sha256:
            return tmp
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    tmp.unlink(missing_ok=True)
    return None


@dataclass
class CachedFile:
    """One file of an entry: its path in a run folder, its size and its SHA-256."""

    path: str
    size: int
    sha256: str


@dataclass
class CacheEntry:
    """What an entry's ``entry.json`` holds: the stage, its key and its files in the order they were written."""

    stage: str
    key: str
    files: list[CachedFile] = field(default_factory=list)


@dataclass(frozen=True)
class EntryProblem:
    """Why an entry is not used: ``file`` (None: the entry as a whole) and what is wrong."""

    file: str | None
    what: str


@dataclass(frozen=True)
class StageCache:
    """The shared stage cache in ``root`` (see the module docstring)."""

    root: Path

    @classmethod
    def default(cls) -> StageCache | None:
        """The cache of ``default_cache_dir()`` (None when turned off or when its place is not a folder)."""
        where = default_cache_dir()
        if where is None:
            return None
        why = not_a_folder(where)
        if why is not None:
            if where not in _warned_not_a_folder:
                _warned_not_a_folder.add(where)
                log.warning("shared stage cache off: %s (set $%s to a folder, or to off)", why, CACHE_ENV)
            return None
        return cls(where)

    def entry_dir(self, stage: str, key: str) -> Path:
        """The folder of the entry of ``stage`` with ``key``."""
        return self.root / "stages" / stage / key

    def check(self, entry: Path, stage: str | None = None, key: str | None = None) -> CacheEntry | EntryProblem:
        """The entry's record when every file has its recorded size and SHA-256, else what is wrong."""
        try:
            rec = read_record(entry / ENTRY_JSON, CacheEntry, ENTRY_SCHEMA)
        except RecordError as err:
            return EntryProblem(None, f"{ENTRY_JSON} unreadable ({err})")
        if (stage is not None and rec.stage != stage) or (key is not None and rec.key != key):
            return EntryProblem(None, f"{ENTRY_JSON} names stage {rec.stage} key {rec.key}")
        for f in rec.files:
            path = entry / "files" / f.path
            try:
                if path.stat().st_size != f.size:
                    return EntryProblem(f.path, f"{path.stat().st_size} bytes, {f.size} recorded")
                if file_sha256(path) != f.sha256:
                    return EntryProblem(f.path, "its SHA-256 differs from the one recorded")
            except OSError as err:
                return EntryProblem(f.path, f"unreadable ({err.strerror or err})")
        return rec

    def _valid(self, stage: str, key: str) -> CacheEntry | None:
        """The entry's record when it exists and is valid; an invalid one is dropped with one warning."""
        entry = self.entry_dir(stage, key)
        if not (entry / ENTRY_JSON).exists():
            return None
        got = self.check(entry, stage, key)
        if isinstance(got, EntryProblem):
            self.drop(entry, got)
            return None
        return got

    def drop(self, entry: Path, problem: EntryProblem) -> None:
        """Remove an invalid entry, with one warning naming the file and what is wrong."""
        where = entry if problem.file is None else entry / "files" / problem.file
        log.warning("shared cache: entry dropped, %s: %s; the stage is computed again", where, problem.what)
        self._remove(entry)

    @staticmethod
    def _remove(entry: Path) -> None:
        gone = _tmp_name(entry)
        try:
            os.rename(entry, gone)
        except OSError:  # already gone (another run dropped it), or not renamable: remove in place
            gone = entry
        shutil.rmtree(gone, ignore_errors=True)

    def lookup(self, stage: str, key: str) -> Path | None:
        """The folder holding a verified entry's files (at their paths in a run folder), or None."""
        return None if self._valid(stage, key) is None else self.entry_dir(stage, key) / "files"

    def fetch(self, stage: str, key: str, run_dir: Path) -> dict[str, str] | None:
        """Copy a verified entry's files into ``run_dir``: path -> SHA-256 in the order written, or None.

        Every file is copied and checked before any is renamed into place, so a file that
        changed in the cache meanwhile leaves the run folder as it was.
        """
        rec = self._valid(stage, key)
        if rec is None:
            return None
        entry = self.entry_dir(stage, key)
        tmps: dict[Path, Path] = {}
        try:
            for f in rec.files:
                tmp = _copy_checked(entry / "files" / f.path, run_dir / f.path, f.sha256)
                if tmp is None:
                    self.drop(entry, EntryProblem(f.path, "its SHA-256 changed while it was copied"))
                    return None
                tmps[tmp] = run_dir / f.path
            for tmp, dst in tmps.items():
                os.replace(tmp, dst)
        except OSError as err:  # the entry went away meanwhile (cleared), or the run folder refused
            log.warning("shared cache: could not take stage %s from %s (%s); computing it", stage, entry, err)
            return None
        finally:
            for tmp in tmps:
                tmp.unlink(missing_ok=True)
        log.info("stage %s: taken from the shared cache (%s)", stage, entry)
        return {f.path: f.sha256 for f in rec.files}

    def publish(self, stage: str, key: str, run_dir: Path, files: Mapping[str, str | None]) -> None:
        """Store ``files`` (path relative to ``run_dir`` -> its SHA-256) as an entry, unless a valid one is there.

        A file whose copy does not have the given SHA-256 (it changed after the run wrote it)
        is not published: nothing of the entry is. A file given with None (wall-clock times,
        which the run's manifest does not hash) is stored with the SHA-256 of its copy.
        """
        entry = self.entry_dir(stage, key)
        if self._valid(stage, key) is not None:
            return
        tmp = _tmp_name(entry)
        try:
            records = []
            for f, sha in files.items():
                copied = _copy_checked(run_dir / f, tmp / "files" / f, sha)
                if copied is None:
                    log.warning(
                        "shared cache: %s changed since the run wrote it; stage %s not stored", run_dir / f, stage
                    )
                    return
                os.replace(copied, tmp / "files" / f)
                stored = tmp / "files" / f
                records.append(CachedFile(f, stored.stat().st_size, sha or file_sha256(stored)))
            write_record(tmp / ENTRY_JSON, CacheEntry(stage, key, records), ENTRY_SCHEMA)
            if entry.exists():  # an invalid entry that could not be dropped: replace it
                self._remove(entry)
            entry.parent.mkdir(parents=True, exist_ok=True)
            os.rename(tmp, entry)
        except (OSError, RomanSimError) as err:
            # another run renamed its copy into place first (ENOTEMPTY / EEXIST), or the cache cannot be written
            if not (isinstance(err, OSError) and err.errno in (errno.ENOTEMPTY, errno.EEXIST)):
                log.warning("shared cache: could not store stage %s in %s (%s)", stage, self.root, err)
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)

    def entries(self) -> list[Path]:
        """The entries' folders, sorted (valid or not; temporary folders left out)."""
        base = self.root / "stages"
        if not base.is_dir():
            return []
        return sorted(
            p
            for stage in base.iterdir()
            if stage.is_dir()
            for p in stage.iterdir()
            if p.is_dir() and not p.name.startswith(".")
        )

    def verify(self) -> tuple[int, list[tuple[Path, EntryProblem]]]:
        """Check every entry: how many are valid, and the invalid ones (each dropped, with its problem)."""
        good, bad = 0, []
        for entry in self.entries():
            got = self.check(entry, entry.parent.name, entry.name)
            if isinstance(got, EntryProblem):
                bad.append((entry, got))
                self._remove(entry)
            else:
                good += 1
        return good, bad

    def size_bytes(self) -> int:
        """Bytes the cache's files take."""
        return sum(p.stat().st_size for p in self.root.rglob("*") if p.is_file()) if self.root.is_dir() else 0

    def clear(self) -> int:
        """Delete every entry; how many there were."""
        n = len(self.entries())
        if (self.root / "stages").exists():
            shutil.rmtree(self.root / "stages")
        return n
