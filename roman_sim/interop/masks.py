"""Instance-mask side files: ``masks/<stamp>.png`` (object id + 1, 16-bit) and ``masks.txt``.

Written next to every exported sequence, so a user can score their own segmenter against
the exact instance labels of each frame (ids as in ``objects.json``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from roman_sim.core.atomic import write_bytes, write_text
from roman_sim.core.errors import StorageError
from roman_sim.core.sensors import Frame
from roman_sim.interop.images import encode_png, ids_to_mask


def list_text(kind: str, robot: str, rows: list[tuple[str, str]]) -> str:
    """A TUM-style image list: three comment lines, then ``timestamp filename`` per image."""
    head = f"# {kind} images\n# robot: {robot} (roman_sim export)\n# timestamp filename\n"
    return head + "".join(f"{s} {f}\n" for s, f in rows)


class MaskWriter:
    """Writes one robot's instance masks under ``out_dir`` (see the module docstring)."""

    def __init__(self, out_dir: Path, robot: str) -> None:
        self.dir = Path(out_dir)
        self.robot = robot
        (self.dir / "masks").mkdir(parents=True, exist_ok=True)
        self.stamps: list[str] = []

    def write(self, frame: Frame, stamp: str) -> None:
        """Write the frame's mask PNG under its time stamp."""
        if frame.truth is None or frame.truth.object_ids is None:
            raise StorageError(f"export: frame {frame.index} of robot {frame.robot} has no instance ids")
        write_bytes(self.dir / "masks" / f"{stamp}.png", encode_png(ids_to_mask(np.asarray(frame.truth.object_ids))))
        self.stamps.append(stamp)

    def close(self) -> Path:
        """Write ``masks.txt``; returns its path."""
        path = self.dir / "masks.txt"
        write_text(
            path,
            list_text(
                "instance mask (object id + 1, 0 = background)",
                self.robot,
                [(s, f"masks/{s}.png") for s in self.stamps],
            ),
        )
        return path
