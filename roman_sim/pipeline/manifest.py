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

import json
import logging
import platform
import sys
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from roman_sim.core.atomic import write_json
from roman_sim.core.errors import StorageError
from roman_sim.core.jsontypes import JSONLike

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

    def to_json(self) -> dict[str, JSONLike]:
        """JSON-ready dict."""
        return {
            "schema": MANIFEST_SCHEMA,
            "scenario": self.scenario,
            "seed": self.seed,
            "config_hash": self.config_hash,
            "package_version": self.package_version,
            "environment": self.environment,
            "expected": self.expected,
            "complete": self.complete,
            "stages": {k: {"key": v.key, "files": v.files} for k, v in self.stages.items()},
        }

    @classmethod
    def from_json(cls, d: object, source: str) -> "Manifest":
        """Inverse of ``to_json``; StorageError names ``source`` when invalid."""
        if not isinstance(d, dict) or d.get("schema") != MANIFEST_SCHEMA:
            raise StorageError(f"{source}: not a run manifest of schema {MANIFEST_SCHEMA}")
        try:
            stages = {str(k): StageRecord(str(v["key"]), [str(f) for f in v["files"]]) for k, v in d["stages"].items()}
            return cls(
                str(d["scenario"]),
                int(d["seed"]),
                str(d["config_hash"]),
                str(d["package_version"]),
                stages,
                [str(s) for s in d["expected"]],
                {str(k): str(v) for k, v in d.get("environment", {}).items()},
            )
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise StorageError(f"{source}: malformed run manifest ({type(err).__name__}: {err})") from None

    def save(self, run_dir: Path) -> None:
        """Write ``manifest.json`` atomically."""
        write_json(run_dir / MANIFEST_JSON, self.to_json())


def read_manifest(run_dir: Path) -> Manifest:
    """The manifest of ``run_dir``.

    Raises:
        StorageError: no manifest (not a run folder) or a corrupt one.
    """
    path = run_dir / MANIFEST_JSON
    if not path.is_file():
        raise StorageError(f"{run_dir}: no {MANIFEST_JSON}: not a run folder (or a run that never started)")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise StorageError(f"{path}: unreadable run manifest ({type(err).__name__})") from None
    return Manifest.from_json(data, str(path))


def existing_manifest(run_dir: Path) -> Manifest | None:
    """The manifest of ``run_dir`` if one is readable; a corrupt one is logged and ignored."""
    try:
        return read_manifest(run_dir)
    except StorageError as err:
        if (run_dir / MANIFEST_JSON).exists():
            log.warning("%s: recomputing every stage", err)
        return None
