"""What every model adapter shares: offline loading from a local folder, torch setup, crops."""

from __future__ import annotations

import importlib
import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roman_sim.core.errors import ConfigError
from roman_sim.core.records import RecordError, read_json
from roman_sim.mapping.mask import Mask


def load_libraries(component: str) -> tuple[Any, Any]:
    """(torch, transformers), imported offline; ``ConfigError`` naming the extra when missing."""
    os.environ["HF_HUB_OFFLINE"] = "1"  # no hub access from any adapter, ever
    os.environ["TRANSFORMERS_OFFLINE"] = "1"
    try:
        torch = importlib.import_module("torch")
        transformers = importlib.import_module("transformers")
    except ImportError as err:
        raise ConfigError(
            f"{component} needs PyTorch and transformers ({err}); install the optional extra: "
            "pip install 'roman_sim[models]'"
        ) from None
    transformers.utils.logging.disable_progress_bar()  # loading logs belong to the caller, not tqdm
    return torch, transformers


def weights_dir(path: Path, field: str, model_types: tuple[str, ...] = ()) -> Path:
    """The local model folder ``path``; a one-line ``ConfigError`` naming ``field`` when it is missing.

    With ``model_types``, the folder's ``config.json`` must declare one of them as ``model_type``.
    """
    p = Path(path).expanduser()
    if not p.is_dir():
        raise ConfigError(
            f"{field}: no model folder at {p} (give a local folder saved with save_pretrained; nothing is downloaded)"
        )
    if not (p / "config.json").is_file():
        raise ConfigError(f"{field}: {p} has no config.json (expected a folder saved with save_pretrained)")
    if model_types:
        try:
            doc = read_json(p / "config.json")  # the model library's own file: only its model_type is read
        except RecordError as err:
            raise ConfigError(f"{field}: cannot read {err}") from None
        kind = doc.get("model_type") if isinstance(doc, dict) else None
        if kind not in model_types:
            raise ConfigError(f"{field}: {p} holds a {kind!r} model, expected {' or '.join(map(repr, model_types))}")
    return p


def load_pretrained(cls: Any, path: Path, field: str, **kwargs: Any) -> Any:
    """``cls.from_pretrained(path, local_files_only=True)``; failures become ``ConfigError`` naming ``field``."""
    try:
        return cls.from_pretrained(str(path), local_files_only=True, **kwargs)
    except (OSError, ValueError, KeyError) as err:
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise ConfigError(f"{field}: cannot load {cls.__name__} from {path}: {first}") from None


def set_threads(torch: Any, threads: int | None) -> None:
    """Limit torch's CPU threads when asked."""
    if threads is not None:
        torch.set_num_threads(int(threads))


def box_crops(rgb: NDArray[np.uint8], masks: list[Mask], min_px: int = 2) -> list[NDArray[np.uint8]]:
    """The bounding-box crop of each mask, grown about its centre to ``min_px`` per side if smaller."""
    h, w = rgb.shape[:2]
    out = []
    for m in masks:
        r0, r1, c0, c1 = m.bbox  # type: ignore[misc]
        r0, r1 = _grow(r0, r1, min_px, h)
        c0, c1 = _grow(c0, c1, min_px, w)
        out.append(np.ascontiguousarray(rgb[r0:r1, c0:c1]))
    return out


def _grow(a: int, b: int, n: int, size: int) -> tuple[int, int]:
    if b - a >= n:
        return a, b
    a = max(0, min((a + b - n) // 2, size - n))
    return a, min(size, a + n)


def unit_rows(x: NDArray[np.floating]) -> NDArray[np.float32]:
    """Rows scaled to unit length (zero rows stay zero), as float32."""
    x = np.asarray(x, dtype=np.float64)
    n = np.linalg.norm(x, axis=1, keepdims=True)
    return (x / np.where(n > 0, n, 1.0)).astype(np.float32)
