"""Atomic file writes: write to a temporary file in the same folder, then rename.

An interrupted process therefore never leaves a half-written result behind. Files get the
mode an ordinary ``open()`` would give them (0666 minus the umask, usually 0644), not the
0600 of the temporary file. ``output_folder`` and ``output_file`` check an output location
before any work, so a file where a folder is meant (or the reverse) is a one-line error.
A full disk or an exhausted quota (ENOSPC, EDQUOT) is a ``StorageError`` naming the file and
the free space left, and the temporary file is removed.
"""

from __future__ import annotations

import errno
import io
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from roman_sim.core.errors import ConfigError, StorageError


@contextmanager
def atomic_open(path: str | Path, mode: str = "wb") -> Iterator[Any]:
    """Open a temporary file next to ``path``; on success rename it over ``path``."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as err:
        raise write_error(path, err) from None
    try:
        os.fchmod(fd, 0o666 & ~current_umask())
        with os.fdopen(fd, mode) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        _replace(tmp, path)
    except BaseException as err:
        if os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(err, OSError) and err.errno in DISK_FULL:  # after the unlink: the free space it leaves
            raise write_error(path, err) from None
        raise


#: errno values of a full disk and of an exhausted quota.
DISK_FULL = (errno.ENOSPC, errno.EDQUOT)


def write_error(path: str | Path, err: OSError) -> StorageError:
    """The one-line ``StorageError`` for an ``OSError`` writing ``path`` (naming the free space on a full disk)."""
    if err.errno in DISK_FULL:
        why = "no space left on device" if err.errno == errno.ENOSPC else "disk quota exceeded"
        return StorageError(f"{path}: cannot write: {why} ({free_space(Path(path).parent)} free there)")
    return StorageError(f"{path}: cannot write ({err.strerror or err})")


def free_space(folder: str | Path) -> str:
    """The space left on the file system of ``folder`` (or its nearest existing parent), e.g. ``12.0 KB``."""
    where = Path(folder).absolute()
    existing = next((p for p in [where, *where.parents] if p.exists()), where.anchor)
    try:
        free = float(shutil.disk_usage(existing).free)
    except OSError:
        return "unknown space"
    units, i = ("B", "KB", "MB", "GB", "TB"), 0
    while free >= 1024 and i < len(units) - 1:
        free, i = free / 1024, i + 1
    return f"{free:.0f} B" if i == 0 else f"{free:.1f} {units[i]}"


def _replace(tmp: str, path: Path) -> None:
    try:
        os.replace(tmp, path)
    except IsADirectoryError:
        raise StorageError(f"{path}: is an existing folder, cannot write a file there") from None
    except OSError as err:
        raise write_error(path, err) from None


def current_umask() -> int:
    """The process umask, read without changing it where Linux exposes it (else set and restored)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def make_public_dir(path: str | Path) -> None:
    """Give a folder made by ``tempfile.mkdtemp`` (mode 0700) the mode of an ordinary ``mkdir``."""
    os.chmod(path, 0o777 & ~current_umask())


def output_folder(path: str | Path, what: str = "--out", create: bool = True) -> Path:
    """Check ``path`` as an output folder and create it (parents too, unless ``create`` is False).

    With ``create=False`` nothing is made: the check is that the folder exists or could be
    created (its nearest existing parent is a writable folder), so a command can check its
    output before any work without leaving an empty folder behind when the work fails.

    Raises:
        ConfigError: naming ``what``: ``path`` or one of its parents is an existing file, or
            the folder cannot be created or written.
    """
    path = Path(path)
    existing = next((p for p in [path, *path.parents] if p.exists() or p.is_symlink()), Path("."))
    if not existing.is_dir():
        where = "is an existing file" if existing == path else f"lies inside {existing}, an existing file"
        raise ConfigError(f"{what} {path}: {where}, not a folder (choose a folder path)")
    if create:
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise ConfigError(f"{what} {path}: cannot create the folder ({err.strerror or err})") from None
        existing = path
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"{what} {path}: {'the folder' if existing == path else existing} is not writable")
    return path


def output_file(path: str | Path, what: str = "--out", create: bool = True) -> Path:
    """Check that ``path`` can be written as a file (its folder is created unless ``create`` is False)."""
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"{what} {path}: is an existing folder, expected a file path")
    output_folder(path.parent, what=what, create=create)
    return path


def write_bytes(path: str | Path, data: bytes) -> None:
    """Atomically write ``data`` to ``path``."""
    with atomic_open(path, "wb") as fh:
        fh.write(data)


def write_text(path: str | Path, text: str) -> None:
    """Atomically write UTF-8 ``text`` to ``path``."""
    write_bytes(path, text.encode("utf-8"))


def write_json(path: str | Path, obj: Any, indent: int | None = 2, tight: bool = False) -> None:
    """Atomically write ``obj`` as JSON (sorted keys: the same data gives the same bytes).

    ``indent=None``: on one line; ``tight``: on one line without spaces after separators.
    """
    seps = (",", ":") if tight else None
    text = json.dumps(obj, indent=None if tight else indent, separators=seps, sort_keys=True, default=_json_default)
    write_text(path, text + "\n")


def write_npz(path: str | Path, compressed: bool = True, **arrays: np.ndarray) -> None:
    """Atomically write arrays to an ``.npz`` file (``write_arrays`` takes them as a mapping)."""
    write_arrays(path, arrays, compressed)


def write_arrays(path: str | Path, arrays: Mapping[str, np.ndarray], compressed: bool = True) -> None:
    """Atomically write the named ``arrays`` to an ``.npz`` file."""
    buf = io.BytesIO()
    # numpy's stub matches the names against savez's own ``allow_pickle: bool``; no array is called that
    (np.savez_compressed if compressed else np.savez)(buf, **arrays)  # type: ignore[arg-type]
    write_bytes(path, buf.getvalue())


def write_with(path: str | Path, writer: Callable[[BinaryIO], None]) -> None:
    """Atomically write ``path`` with ``writer(fh)`` (a binary file handle)."""
    with atomic_open(path, "wb") as fh:
        writer(fh)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
