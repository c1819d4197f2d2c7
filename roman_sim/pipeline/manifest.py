"""``manifest.json``: what a run folder holds, so that nothing stale is ever read or reported.

The manifest records the hash of the resolved configuration, the package version, the
versions of the libraries whose arithmetic reaches the results (``environment``: a new
OpenCV, MuJoCo or numpy may change the last bits of a result, or more; the stages' keys
include the versions of the libraries each stage runs, so every recorded stage was made
with them) and, per completed stage, its cache key and the files it wrote (relative paths,
in the order the stage wrote them) with each file's SHA-256. A stage's outputs are reused
only when its recorded key matches and every recorded file exists with its recorded
SHA-256 (``Manifest.check``): a file changed after the stage wrote it makes the stage run
again, with a warning naming the file. Outputs are read only from the files the manifest
lists (never by globbing the folder). A run is complete when every stage of its scenario is
recorded. Wall-clock figures live elsewhere (``timings.json``), so two runs of one seed
write the same manifest, whether a stage was computed, reused or taken from the shared
cache.
"""

from __future__ import annotations

import logging
import platform
from dataclasses import dataclass, field, replace
from importlib import metadata
from pathlib import Path

from roman_sim.core.errors import StorageError
from roman_sim.core.records import OMIT_NONE, read_record, write_record
from roman_sim.pipeline.stagecache import file_sha256

log = logging.getLogger(__name__)

MANIFEST_JSON = "manifest.json"
MANIFEST_SCHEMA = "roman_sim.run/1"

# Distributions whose versions a run records: each entry is one library, under any of the
# names it is published as (the first one installed is recorded).
ENVIRONMENT_DISTRIBUTIONS: tuple[tuple[str, ...], ...] = (
    ("numpy",),
    ("scipy",),
    ("mujoco",),
    ("opencv-python-headless", "opencv-python", "opencv-contrib-python-headless", "opencv-contrib-python"),
    ("gtsam",),
    ("trimesh",),
    ("scikit-learn",),
    ("torch",),
)


def environment() -> dict[str, str]:
    """Python's version and those of the installed ``ENVIRONMENT_DISTRIBUTIONS`` (missing ones left out)."""
    out = {"python": platform.python_version()}
    for names in ENVIRONMENT_DISTRIBUTIONS:
        for name in names:
            try:
                out[name] = metadata.version(name)
            except metadata.PackageNotFoundError:
                continue
            break
    return out


#: Name endings of files that hold wall-clock times (they differ between two runs of one seed).
WALL_TIME_FILES = ("timings.json", ".times.json")


def is_wall_time_file(path: str) -> bool:
    """Whether the run-folder file ``path`` holds wall-clock times (``timings.json``, ``<label>.times.json``)."""
    return path.rsplit("/", 1)[-1].endswith(WALL_TIME_FILES)


@dataclass
class StageRecord:
    """One completed stage: its cache key, the files it wrote (relative to the run folder, in the
    order written) and each file's SHA-256 (None in manifests written before hashes were kept)."""

    key: str
    files: list[str]
    sha256: dict[str, str] | None = field(default=None, metadata=OMIT_NONE)

    @classmethod
    def of(cls, key: str, run_dir: Path, files: list[str]) -> StageRecord:
        """The record of ``files`` as they are in ``run_dir`` now: the SHA-256 of each, wall-time files aside.

        A file of wall-clock times (``is_wall_time_file``) differs between two runs of one seed,
        so its hash would make the manifest differ too: it is recorded without one (its
        presence is still checked).
        """
        return cls(key, list(files), {f: file_sha256(run_dir / f) for f in files if not is_wall_time_file(f)})

    def hashes(self) -> dict[str, str]:
        """Path -> SHA-256 of the files recorded with one, in the order written (empty without hashes)."""
        return {f: self.sha256[f] for f in self.files if f in self.sha256} if self.sha256 else {}

    def changed(self, run_dir: Path) -> str | None:
        """Why the files in ``run_dir`` are not the ones recorded (a file missing or changed), or None."""
        if self.sha256 is None:
            return "no SHA-256 recorded for its files"
        for f in self.files:
            path = run_dir / f
            if not path.is_file():
                return f"{path} is missing"
            if f not in self.sha256:
                continue
            try:
                if file_sha256(path) != self.sha256[f]:
                    return f"{path} changed after the stage wrote it (its SHA-256 differs from {MANIFEST_JSON}'s)"
            except OSError as err:
                return f"{path} is unreadable ({err.strerror or err})"
        return None


@dataclass
class Manifest:
    """The record of a run folder (see the module docstring)."""

    scenario: str
    seed: int
    config_hash: str
    package_version: str
    stages: dict[str, StageRecord] = field(default_factory=dict)
    expected: list[str] = field(default_factory=list)
    environment: dict[str, str] = field(default_factory=dict)

    @property
    def missing(self) -> list[str]:
        """Stages of the run that have not completed."""
        return [s for s in self.expected if s not in self.stages]

    @property
    def complete(self) -> bool:
        """Whether every stage of the run completed."""
        return not self.missing

    def check(self, stage: str, key: str, run_dir: Path) -> str | None:
        """None when ``stage`` is recorded with ``key`` and every file is as recorded, else why not."""
        rec = self.stages.get(stage)
        if rec is None:
            return "not recorded"
        if rec.key != key:
            return "recorded with another key"
        return rec.changed(run_dir)

    def valid(self, stage: str, key: str, run_dir: Path) -> bool:
        """Whether ``stage`` is recorded with ``key`` and all of its files are as recorded (``check``)."""
        return self.check(stage, key, run_dir) is None

    def without_hashes(self) -> Manifest:
        """The manifest with no file's SHA-256 (for a copy of a run whose files are not all the run's)."""
        stages = {name: StageRecord(rec.key, list(rec.files)) for name, rec in self.stages.items()}
        return replace(self, stages=stages)

    def record(self) -> ManifestRecord:
        """The manifest as its ``manifest.json`` record (with ``complete`` spelled out)."""
        return ManifestRecord(
            self.scenario,
            self.seed,
            self.config_hash,
            self.package_version,
            self.expected,
            self.complete,
            self.stages,
            self.environment,
        )

    @classmethod
    def from_record(cls, rec: ManifestRecord) -> "Manifest":
        """Inverse of ``record`` (manifests written before ``environment`` existed read with none)."""
        return cls(
            rec.scenario,
            rec.seed,
            rec.config_hash,
            rec.package_version,
            rec.stages,
            rec.expected,
            dict(rec.environment or {}),
        )

    def save(self, run_dir: Path) -> None:
        """Write ``manifest.json`` atomically."""
        write_record(run_dir / MANIFEST_JSON, self.record(), MANIFEST_SCHEMA)


@dataclass
class ManifestRecord:
    """What ``manifest.json`` holds: the ``Manifest`` and whether the run is complete."""

    scenario: str
    seed: int
    config_hash: str
    package_version: str
    expected: list[str]
    complete: bool
    stages: dict[str, StageRecord]
    environment: dict[str, str] | None = field(default=None, metadata=OMIT_NONE)


def read_manifest(run_dir: Path) -> Manifest:
    """The manifest of ``run_dir``.

    Raises:
        StorageError: no manifest (not a run folder) or a corrupt one.
    """
    path = run_dir / MANIFEST_JSON
    if not path.is_file():
        raise StorageError(f"{run_dir}: no {MANIFEST_JSON}: not a run folder (or a run that never started)")
    return Manifest.from_record(read_record(path, ManifestRecord, MANIFEST_SCHEMA))


def changed_files(run_dir: Path, man: Manifest) -> list[str]:
    """The files of ``run_dir`` whose bytes are not those ``man`` recorded, one line each (present files only).

    Stages recorded without hashes (manifests written before hashes were kept) are not checked.
    """
    out = []
    for rec in man.stages.values():
        for f, sha in rec.hashes().items():
            path = run_dir / f
            if path.is_file() and file_sha256(path) != sha:
                out.append(f"{path} changed after the run wrote it (its SHA-256 differs from {MANIFEST_JSON}'s)")
    return out


def existing_manifest(run_dir: Path) -> Manifest | None:
    """The manifest of ``run_dir`` if one is readable; a corrupt one is logged and ignored."""
    try:
        return read_manifest(run_dir)
    except StorageError as err:
        if (run_dir / MANIFEST_JSON).exists():
            log.warning("%s: recomputing every stage", err)
        return None
