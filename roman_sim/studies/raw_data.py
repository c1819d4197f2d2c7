"""Raw data the reference results keep for the independent scorer: packets and per-pair runtimes.

- ``packets/<robot>.npz``: every submap packet of a robot as it would be sent
  (``roman_sim.mapping.io.packet_arrays``): per submap k the arrays ``s<k>_<field>``, except
  the descriptors, which are per segment, not per submap (a segment belongs to several
  submaps with one descriptor): they are stored once, as ``descriptor_ids`` (segment ids,
  int32) and ``descriptor_table`` (float16 rows). Rebuilding submap k's descriptors is a
  lookup of its ``segment_ids`` in that table.
- ``runtimes.csv``: ``a, b, method, runtime_s``, one row per pair and method, in the order of
  ``pairs.csv`` (wall-clock times: like ``timings.json``, never part of the reproducible
  outputs).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from roman_sim.core.atomic import write_arrays, write_bytes
from roman_sim.core.errors import StorageError
from roman_sim.evaluation.records import read_timings
from roman_sim.mapping.io import load_submaps, packet_arrays
from roman_sim.mapping.types import Submap

PACKETS_DIR = "packets"
RUNTIMES_CSV = "runtimes.csv"


def packet_file_arrays(submaps: list[Submap]) -> dict[str, np.ndarray]:
    """The arrays of one robot's packets file (see the module docstring)."""
    arrays: dict[str, np.ndarray] = {}
    table: dict[int, np.ndarray] = {}
    for k, s in enumerate(submaps):
        packet = packet_arrays(s)
        for sid, row in zip(packet["segment_ids"].tolist(), packet["descriptors"]):
            if sid in table and not np.array_equal(table[sid], row):
                raise StorageError(f"submap {s.index}: segment {sid} has two descriptors; packets cannot share them")
            table.setdefault(sid, row)
        arrays.update({f"s{k}_{name}": v for name, v in packet.items() if name != "descriptors"})
    ids = sorted(table)
    dim = next(iter(table.values())).shape[0] if table else 0
    arrays["descriptor_ids"] = np.asarray(ids, dtype=np.int32)
    arrays["descriptor_table"] = (
        np.stack([table[i] for i in ids]).astype(np.float16) if ids else np.zeros((0, dim), np.float16)
    )
    return arrays


def write_packets(run_dir: Path, dest: Path) -> list[Path]:
    """``dest/packets/<robot>.npz`` for every ``run_dir/submaps/<robot>.npz``; the files written."""
    out = []
    for path in sorted((run_dir / "submaps").glob("*.npz")):
        target = dest / PACKETS_DIR / path.name
        write_arrays(target, packet_file_arrays(load_submaps(path)))
        out.append(target)
    return out


def write_runtimes(run_dir: Path, dest: Path) -> Path | None:
    """``dest/runtimes.csv`` from the run's per-pair runtimes (``timings.json``) and ``pairs.csv`` order.

    None when the run kept no per-pair runtimes.
    """
    if not (run_dir / "timings.json").is_file():
        return None
    evaluation = read_timings(run_dir / "timings.json").stages.get("evaluation")
    alignment = {} if evaluation is None or evaluation.alignment is None else evaluation.alignment
    per_pair = {m: list(v.per_pair_s or []) for m, v in alignment.items()}
    if not any(per_pair.values()):
        return None
    with (run_dir / "pairs.csv").open(encoding="utf-8", newline="") as fh:
        rows = [(r["a"], r["b"], r["method"]) for r in csv.DictReader(fh)]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["a", "b", "method", "runtime_s"])
    seen: dict[str, int] = {}
    for a, b, m in rows:
        i = seen.get(m, 0)
        seen[m] = i + 1
        times = per_pair.get(m, [])
        if i >= len(times):
            raise StorageError(f"{run_dir / 'timings.json'}: {len(times)} runtimes of {m}, pairs.csv has more pairs")
        w.writerow([a, b, m, repr(float(times[i]))])
    target = dest / RUNTIMES_CSV
    write_bytes(target, buf.getvalue().encode("utf-8"))
    return target
