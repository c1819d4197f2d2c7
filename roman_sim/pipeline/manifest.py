"""``manifest.json``: what a run folder holds, so that nothing stale is ever read or reported.

The manifest records the hash of the resolved configuration, the package version, the
versions of the libraries whose arithmetic reaches the results (``environment``: a new
OpenCV, MuJoCo or numpy may change the last bits of a result, or more) and, per completed
stage, its cache key and the files it wrote (relative paths). A stage's outputs
are reused only when its recorded key matches and every recorded file exists; outputs are
read only from the files the manifest lists (never by globbing the folder). A run is
complete when every stage of its scenario is recorded. Wall-clock figures live elsewhere
(``timings.json``), so two runs of one seed write the same manifest.
"""

from __future__ import annotations

import logging
import platform
import sys
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSON
from roman_sim.core.records import OMIT_NONE, from_json, read_record, to_json_record, write_record

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


def environment_changes(old: dict[str, str], new: dict[str, str]) -> list[str]:
    """``"name old -> new"`` for every library whose version differs (absent: ``none``)."""
    return [
        f"{k} {old.get(k, 'none')} -> {new.get(k, 'none')}"
        for k in sorted(set(old) | set(new))
        if old.get(k) != new.get(k)
    ]


#: Libraries only some runs import (a front end that runs a real model), by the module they import
#: as: a resume warns about their versions only when this process imported them.
ON_DEMAND = {"torch": "torch"}


def used_changes(old: dict[str, str], new: dict[str, str]) -> list[str]:
    """``environment_changes`` of the libraries this run uses (``ON_DEMAND`` ones only when imported)."""
    skip = {name for name, module in ON_DEMAND.items() if module not in sys.modules}
    return environment_changes(
        {k: v for k, v in old.items() if k not in skip}, {k: v for k, v in new.items() if k not in skip}
    )


@dataclass
class StageRecord:
    """One completed stage: its cache key and the files it wrote (relative to the run folder)."""

    key: str
    files: list[str]


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

    def valid(self, stage: str, key: str, run_dir: Path) -> bool:
        """Whether ``stage`` is recorded with ``key`` and all of its files exist."""
        rec = self.stages.get(stage)
        return bool(rec and rec.key == key and all((run_dir / f).is_file() for f in rec.files))

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

    def to_json(self) -> JSON:
        """JSON-ready dict (with its schema tag)."""
        return to_json_record(self.record(), MANIFEST_SCHEMA)

    @classmethod
    def from_json(cls, d: object, source: str) -> "Manifest":
        """Inverse of ``to_json``; RecordError names ``source`` and the field when invalid."""
        return cls.from_record(from_json(ManifestRecord, d, source, MANIFEST_SCHEMA))

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


def existing_manifest(run_dir: Path) -> Manifest | None:
    """The manifest of ``run_dir`` if one is readable; a corrupt one is logged and ignored."""
    try:
        return read_manifest(run_dir)
    except StorageError as err:
        if (run_dir / MANIFEST_JSON).exists():
            log.warning("%s: recomputing every stage", err)
        return None
