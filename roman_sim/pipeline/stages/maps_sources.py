"""Robots read from recorded sequences (``source: {tum: folder}``) instead of simulated.

Such a robot's frames come from ``roman_sim.interop.tum_reader``; the evaluation scores it
against the sequence's ground truth (``groundtruth.txt``, required), and, when the folder
has instance masks (an exported sequence), its segments carry true object ids as a
simulated robot's do. The simulated encoder needs the objects' families: they come from the
sequence's object table (``objects.json``, next to the folder in an export). The maps
stage's cache key includes a fingerprint of the folder (file names and sizes, the text
files' contents), so a changed sequence is mapped again.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import TYPE_CHECKING

from roman_sim.core.errors import ConfigError
from roman_sim.interop.objects import OBJECTS_JSON, read_object_table
from roman_sim.interop.tum_reader import TumSequence, TumSourceConfig

if TYPE_CHECKING:
    from roman_sim.pipeline.scenario import ScenarioRobot

_TEXT_SUFFIXES = (".txt", ".yaml", ".json")


def open_sequence(cfg: ScenarioRobot, seed: int) -> TumSequence:
    """The robot's associated sequence (ConfigError when it has no ground truth to score against)."""
    if cfg.source is None:
        raise ConfigError(f"robot {cfg.name}: not read from a sequence (no source)")
    seq = TumSequence(cfg.source, robot=cfg.name, seed=seed)
    if seq.T_world_body is None:
        raise ConfigError(
            f"robot {cfg.name}: source.tum {seq.dir} has no groundtruth.txt; the evaluation "
            "scores every robot against its true trajectory"
        )
    return seq


def object_table_path(source: TumSourceConfig) -> Path | None:
    """``source.objects``, else ``objects.json`` in the folder or its parent (None when absent)."""
    if source.objects is not None:
        if not Path(source.objects).is_file():
            raise ConfigError(f"source.objects {source.objects}: file not found")
        return Path(source.objects)
    folder = Path(source.tum)
    return next((p for p in (folder / OBJECTS_JSON, folder.parent / OBJECTS_JSON) if p.is_file()), None)


def sequence_families(source: TumSourceConfig) -> dict[int, str] | None:
    """Object id -> family from the sequence's object table (None without one)."""
    path = object_table_path(source)
    return None if path is None else {r.id: r.family for r in read_object_table(path)}


def fingerprint(source: TumSourceConfig) -> dict[str, str]:
    """What the folder's mapping depends on: every file's size, and the text files' digests."""
    folder = Path(source.tum)
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            rel = p.relative_to(folder).as_posix()
            text = p.suffix in _TEXT_SUFFIXES
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest() if text else str(p.stat().st_size)
    table = object_table_path(source)
    if table is not None:
        out["<objects>"] = hashlib.sha256(table.read_bytes()).hexdigest()
    return out


def fingerprints(robots: list[ScenarioRobot]) -> dict[str, dict[str, str]]:
    """Robot name -> ``fingerprint`` of its folder, for the robots read from a sequence."""
    return {r.name: fingerprint(r.source) for r in robots if r.source is not None}


def object_tables(robots: list[ScenarioRobot]) -> list[Path]:
    """The object tables of the robots read from sequences, sorted, each once."""
    return sorted({p for r in robots if r.source is not None and (p := object_table_path(r.source)) is not None})
