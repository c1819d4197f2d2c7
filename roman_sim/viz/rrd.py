"""Read a rerun recording back with rerun's own reader (``rerun.chunk.RrdReader``).

``recording_contents`` lists, per entity path, every component logged there and the
number of instances of each logged row (e.g. ``Boxes3D:centers`` -> ``[412]`` for one static
row of 412 boxes; ``Image:buffer`` -> ``[1, 1, ...]`` one per frame on the timeline).
"""

from __future__ import annotations

from pathlib import Path

from roman_sim.core.errors import StorageError

Contents = dict[str, dict[str, list[int]]]


def recording_contents(path: str | Path) -> Contents:
    """Entity path -> component -> instance count per logged row (chunk order)."""
    import pyarrow.compute as pc
    from rerun.chunk import RrdReader

    p = Path(path)
    if not p.is_file():
        raise StorageError(f"{p}: recording not found")
    try:
        chunks = list(RrdReader(p).stream())
    except (OSError, ValueError, RuntimeError) as err:
        raise StorageError(f"{p}: not a readable rerun recording ({err})") from None
    out: Contents = {}
    for chunk in chunks:
        batch = chunk.to_record_batch()
        per = out.setdefault(str(chunk.entity_path), {})
        for name, column in zip(batch.schema.names, batch.columns):
            meta = batch.schema.field(name).metadata or {}
            if b"rerun:component" not in meta:
                continue  # row ids and time columns
            lengths = pc.fill_null(pc.list_value_length(column), 0)
            per.setdefault(name, []).extend(int(n) for n in lengths.to_pylist())
    return out
